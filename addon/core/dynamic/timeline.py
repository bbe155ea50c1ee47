"""Scene frames -> a dynamic capture's own time: a pure function of the settings and the frame.

A capture's time runs over [time_start, time_end] in its own unit: seconds (.4dgs, linear-
motion captures), or segments (Spacetime Gaussians: t from 0 to 1 over each segment file,
segment k of a multi-segment capture over [k, k + 1]). Defaults, applied on import:
capture time 0 sits at the scene's start frame; a capture in seconds plays in real time at
the scene's frame rate (frames_per_unit = fps); a Spacetime segment spans 50 frames, as its
training configs do. A keyed capture time replaces the mapping (slow motion, freeze and
reverse are then keyframes); the loop mode applies to either.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

HOLD, LOOP, PING_PONG = "HOLD", "LOOP", "PING_PONG"
MODES = (HOLD, LOOP, PING_PONG)
SECONDS, SEGMENT = "SECONDS", "SEGMENT"
SEGMENT_FRAMES = 50.0  # Spacetime Gaussians' configs: duration 50 frames per segment


@dataclass(frozen=True)
class Mapping:
    time_start: float
    time_end: float
    start_frame: float = 1.0
    frames_per_unit: float = 24.0
    mode: str = HOLD
    capture_time: float | None = None  # keyed: shown as is (after the loop mode)


def default_frames_per_unit(unit: str, scene_fps: float) -> float:
    return SEGMENT_FRAMES if unit == SEGMENT else float(scene_fps)


def capture_time(mapping: Mapping, frame: float) -> float:
    """The capture time shown at scene `frame` (fractional for motion-blur sub-frames)."""
    if mapping.capture_time is not None:
        t = float(mapping.capture_time)
    else:
        t = mapping.time_start + (frame - mapping.start_frame) / mapping.frames_per_unit
    return fold(t, mapping.time_start, mapping.time_end, mapping.mode)


def fold(t: float, start: float, end: float, mode: str) -> float:
    """t brought into [start, end]: clamped (HOLD), wrapped (LOOP) or reflected (PING_PONG).
    A non-finite t shows the start; an empty range shows its one moment."""
    if mode not in MODES:
        raise ValueError(f"unknown loop mode {mode!r}; known: {', '.join(MODES)}")
    span = end - start
    if not math.isfinite(t) or not span > 0.0:
        return float(start)
    if mode == HOLD:
        return min(max(t, start), end)
    local = (t - start) % (2.0 * span if mode == PING_PONG else span)
    if mode == LOOP:
        # the last moment of a loop is its first again; within it, time runs on
        return start + local
    return start + (local if local <= span else 2.0 * span - local)
