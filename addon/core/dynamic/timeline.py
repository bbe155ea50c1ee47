"""Scene frame -> capture time: a pure function, no state.

Capture time 0 of the playback (the capture's t_start) falls on the scene's start frame.
A capture in seconds plays in real time at the scene's fps; one in Spacetime segment units
plays a segment per SEGMENT_FRAMES frames (Spacetime Gaussians train a segment of 50
frames with t = (frame - start) / 50). `speed` multiplies the rate; `frames_per_unit`
overrides it. After the capture's range:
  LOOP      wraps to the start (t_end itself is never returned: it is t_start again)
  HOLD      stays on the first / last time
  PINGPONG  plays backwards to the start, then forwards again
"""
from __future__ import annotations

import math

MODES = ("LOOP", "HOLD", "PINGPONG")
SEGMENT_FRAMES = 50


def frames_per_unit_for(unit: str, scene_fps: float) -> float:
    """Scene frames per capture time unit by default."""
    return float(scene_fps) if unit == "seconds" else float(SEGMENT_FRAMES)


def capture_time(frame: float, *, start_frame: float, scene_fps: float, capture, mode: str = "LOOP",
                 speed: float = 1.0, frames_per_unit: float | None = None) -> float:
    """Capture time shown on scene `frame`. `capture` needs t_start, t_end and unit (a
    DynamicCapture). A zero-length range always gives t_start."""
    if mode not in MODES:
        raise ValueError(f"mode {mode!r} is not one of {MODES}")
    per_unit = frames_per_unit_for(capture.unit, scene_fps) if frames_per_unit is None else float(frames_per_unit)
    if not (per_unit > 0 and math.isfinite(per_unit)):
        raise ValueError(f"frames per capture unit must be positive, got {per_unit}")
    start, span = float(capture.t_start), float(capture.t_end) - float(capture.t_start)
    elapsed = (float(frame) - float(start_frame)) * float(speed) / per_unit
    if not (span > 0) or not math.isfinite(elapsed):
        return start
    if mode == "HOLD":
        return start + min(max(elapsed, 0.0), span)
    if mode == "LOOP":
        return start + _wrap(elapsed, span)
    phase = _wrap(elapsed, 2.0 * span)
    return start + (phase if phase <= span else 2.0 * span - phase)


def _wrap(x: float, period: float) -> float:
    """x modulo period in [0, period) (math.fmod keeps the sign; rounding can give period)."""
    r = math.fmod(x, period)
    if r < 0:
        r += period
    return 0.0 if r >= period else r
