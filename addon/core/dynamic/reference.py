"""The float64 reference for DynamicCapture.at: each model's formulas written out plainly,
splat by splat in vector form, for tests to pin the float32 fast path (evaluate.py) to."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .capture import ALPHA_MIN, DynamicCapture


@dataclass
class ReferenceFrame:
    """The capture at time t in float64: kept splats' capture indices and their state."""

    index: np.ndarray       # (M,) int64, ascending
    positions: np.ndarray   # (M, 3)
    rotations: np.ndarray   # (M, 4) unit w, x, y, z
    opacities: np.ndarray   # (M,)
    zero_rotations: int


def _f64(a):
    return np.asarray(a, np.float64)


def _temporal(capture: DynamicCapture, rows: slice, delta: np.ndarray) -> np.ndarray:
    """The time factor of the opacity: spacetime/linear exp(-(Delta/s)^2); 4dgs
    exp(-1/2 (Delta/sigma)^2), 1 where sigma is +inf. Delta/0 at Delta = 0 counts as 0."""
    width = _f64(capture.t_scale[rows])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(delta == 0.0, 0.0, delta / width)
    if capture.model == "4dgs":
        return np.where(np.isinf(width), 1.0, np.exp(-0.5 * ratio ** 2))
    return np.exp(-(ratio ** 2))


def _centre(capture: DynamicCapture, rows: slice, delta: np.ndarray) -> np.ndarray:
    centre = _f64(capture.positions[rows]).copy()
    motion = _f64(capture.motion[rows])
    for term in range(motion.shape[1]):  # term d multiplies Delta^(d + 1)
        centre += motion[:, term] * delta[:, None] ** (term + 1)
    return centre


def _rotation(capture: DynamicCapture, rows: slice, delta: np.ndarray):
    q = _f64(capture.rotations[rows]).copy()
    if capture.omega is not None and capture.model != "4dgs":
        q += _f64(capture.omega[rows]) * delta[:, None]
    norm = np.sqrt(np.sum(q * q, axis=1))
    usable = norm > 0
    q[usable] /= norm[usable, None]
    return q, usable


def reference_at(capture: DynamicCapture, t: float) -> ReferenceFrame:
    """What `capture.at(t)` computes, in float64 from the capture's stored float32 values."""
    k, local = capture.segment_at(float(t))
    a, b = int(capture.segment_offsets[k]), int(capture.segment_offsets[k + 1])
    rows = slice(a, b)
    delta = local - _f64(capture.t_center[rows])
    temporal = _temporal(capture, rows, delta)
    opacity = _f64(capture.opacities[rows]) * temporal
    keep = opacity >= ALPHA_MIN
    if capture.model == "4dgs":
        keep &= temporal >= capture.cutoff
        if capture.window is not None:
            keep &= (capture.window[rows, 0] <= local) & (local < capture.window[rows, 1])
    centre = _centre(capture, rows, delta)
    rotation, usable = _rotation(capture, rows, delta)
    zero = int(np.count_nonzero(keep & ~usable))
    keep &= usable & np.isfinite(centre).all(axis=1)
    return ReferenceFrame(index=np.flatnonzero(keep).astype(np.int64) + a, positions=centre[keep],
                          rotations=rotation[keep], opacities=opacity[keep], zero_rotations=zero)
