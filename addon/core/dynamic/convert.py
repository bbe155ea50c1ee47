"""Conversions between the time models, and baking a capture to a static SplatSet.

What each keeps or loses (docs/formats.md has the table):
- linear -> spacetime: exact (m2 = m3 = omega = 0).
- spacetime -> linear: exact where m2, m3 and omega are all zero; refused otherwise.
- spacetime/linear -> 4dgs: the motion must be linear and omega zero (refused otherwise);
  t_scale s becomes sigma = s / sqrt(2) (the same curve), times scale to seconds. Lost: the
  splats' faint tails, since .4dgs hides a splat whose time factor is below its 0.05 cut-off
  (Splatline's spacetime model keeps it while its opacity is >= 1/255); rotations are
  normalised (4dgs orientations are fixed unit quaternions).
- 4dgs -> linear: refused where a validity window is finite; sigma becomes s = sigma sqrt(2).
  Lost: the 0.05 cut-off (the splat then fades out only below opacity 1/255).
Every conversion keeps the splats' order, so indices stay valid.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import SplatFormatError
from ..sh import C0
from ..splats import AXES_RDF, SplatSet
from .capture import FOURDGS_CUTOFF, DynamicCapture

SQRT2 = math.sqrt(2.0)


def bake(capture: DynamicCapture, t: float) -> SplatSet:
    """The capture at time t as a static SplatSet (its `at(t)`; Frame.index says which splats)."""
    return capture.at(t).splats


def _refuse_nonlinear(capture: DynamicCapture, target: str) -> None:
    cubic = int(np.count_nonzero(capture.motion[:, 1:].any(axis=(1, 2))))
    turning = 0 if capture.omega is None else int(np.count_nonzero(capture.omega.any(axis=1)))
    if cubic or turning:
        raise SplatFormatError(capture.source, f"{target} holds only linear motion and fixed rotations: "
                                               f"{cubic} splats have quadratic/cubic motion, {turning} an omega")


def to_spacetime(capture: DynamicCapture) -> DynamicCapture:
    if capture.model == "spacetime":
        return capture
    if capture.model == "4dgs":
        capture = to_linear(capture)
    n = capture.count
    motion = np.zeros((n, 3, 3), np.float32)
    motion[:, :1] = capture.motion
    return replace(capture, model="spacetime", motion=motion, omega=np.zeros((n, 4), np.float32),
                   dropped=dict(capture.dropped))


def to_linear(capture: DynamicCapture) -> DynamicCapture:
    if capture.model == "linear":
        return capture
    if capture.model == "spacetime":
        _refuse_nonlinear(capture, "a linear-motion capture")
        return replace(capture, model="linear", motion=np.ascontiguousarray(capture.motion[:, :1]), omega=None,
                       dropped=dict(capture.dropped))
    if capture.window is not None and np.isfinite(capture.window).any():
        finite = int(np.count_nonzero(np.isfinite(capture.window).any(axis=1)))
        raise SplatFormatError(capture.source, f"{finite} splats have a finite validity window, which a "
                                               f"linear-motion capture cannot hold")
    return replace(capture, model="linear", t_scale=(capture.t_scale.astype(np.float64) * SQRT2).astype(np.float32),
                   window=None, cutoff=None, dropped=dict(capture.dropped))


def to_fourdgs(capture: DynamicCapture, seconds_per_unit: float | None = None) -> DynamicCapture:
    """The 4dgs model in seconds. A capture in segment units needs seconds_per_unit
    (a 50-frame segment at 30 fps: 50 / 30)."""
    if capture.model == "4dgs":
        return capture
    _refuse_nonlinear(capture, "a .4dgs capture")
    if capture.segments != 1:
        raise SplatFormatError(capture.source, "join of several segments into one .4dgs capture is not supported")
    if seconds_per_unit is None:
        if capture.unit != "seconds":
            raise SplatFormatError(capture.source, "a capture in segment units needs seconds_per_unit for .4dgs")
        seconds_per_unit = 1.0
    k = float(seconds_per_unit)
    q = capture.rotations.astype(np.float64)
    norm = np.linalg.norm(q, axis=1)
    q = np.where(norm[:, None] > 0, q / np.where(norm > 0, norm, 1.0)[:, None], [1.0, 0.0, 0.0, 0.0])
    return replace(
        capture, model="4dgs", motion=(capture.motion[:, :1] / k).astype(np.float32), omega=None,
        rotations=q.astype(np.float32), t_center=(capture.t_center.astype(np.float64) * k).astype(np.float32),
        t_scale=(capture.t_scale.astype(np.float64) * k / SQRT2).astype(np.float32), window=None,
        cutoff=FOURDGS_CUTOFF, unit="seconds", t_start=capture.t_start * k, t_end=capture.t_end * k,
        fps=capture.fps, dropped=dict(capture.dropped), source=capture.source)


def from_fourdgs_arrays(positions, scales, rotations, colors, motions, mu_t, sigma_t, win_lo, win_hi,
                        cutoff: float = FOURDGS_CUTOFF, duration: float | None = None,
                        axes: str = AXES_RDF) -> DynamicCapture:
    """A 4dgs-model capture from the arrays of a fourdgs GaussianSet (rotations x, y, z, w;
    linear RGBA colours; motions per second). Higher SH is not taken (fourdgs stores it
    quantised to bytes). Time range: [0, duration] where given, else the windows' or the
    time centres' span."""
    xyzw = np.asarray(rotations, np.float64)
    wxyz = xyzw[:, [3, 0, 1, 2]]
    norm = np.linalg.norm(wxyz, axis=1)
    wxyz = np.where(norm[:, None] > 0, wxyz / np.where(norm > 0, norm, 1.0)[:, None], [1.0, 0.0, 0.0, 0.0])
    colors = np.asarray(colors, np.float64)
    n = wxyz.shape[0]
    window = np.stack([np.asarray(win_lo, np.float64), np.asarray(win_hi, np.float64)], axis=1)
    mu = np.asarray(mu_t, np.float32)
    if duration is None:
        finite = window[np.isfinite(window)]
        span = finite if finite.size else mu.astype(np.float64)
        t_start, t_end = (float(span.min()), float(span.max())) if span.size else (0.0, 0.0)
    else:
        t_start, t_end = 0.0, float(duration)
    return DynamicCapture(
        model="4dgs", positions=np.asarray(positions, np.float32).copy(),
        motion=np.asarray(motions, np.float32).reshape(n, 1, 3).copy(), rotations=wxyz.astype(np.float32),
        omega=None, scales=np.asarray(scales, np.float32).copy(), opacities=colors[:, 3].astype(np.float32),
        sh_dc=((colors[:, :3] - 0.5) / C0).astype(np.float32), sh_rest=np.zeros((n, 0, 3), np.float32),
        t_center=mu.copy(), t_scale=np.asarray(sigma_t, np.float32).copy(), window=window, cutoff=float(cutoff),
        axes=axes, t_start=t_start, t_end=t_end, unit="seconds", duration=duration, source="4dgs arrays").check()


def to_fourdgs_arrays(capture: DynamicCapture) -> dict:
    """A 4dgs-model capture as fourdgs.GaussianSet keyword arguments (the colour is
    0.5 + C0 dc clamped to [0, 1], as fourdgs' own PLY conversion does)."""
    if capture.model != "4dgs":
        raise ValueError("convert with to_fourdgs first")
    rgb = np.clip(C0 * capture.sh_dc.astype(np.float64) + 0.5, 0.0, 1.0)
    window = capture.window if capture.window is not None else np.tile([-np.inf, np.inf], (capture.count, 1))
    return dict(positions=capture.positions.copy(), scales=capture.scales.copy(),
                rotations=np.ascontiguousarray(capture.rotations[:, [1, 2, 3, 0]]),
                colors=np.concatenate([rgb, capture.opacities[:, None]], axis=1).astype(np.float32),
                motions=capture.motion[:, 0].copy(), mu_t=capture.t_center.copy(), sigma_t=capture.t_scale.copy(),
                win_lo=window[:, 0].copy(), win_hi=window[:, 1].copy())
