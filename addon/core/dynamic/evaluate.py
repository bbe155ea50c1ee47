"""The float32 fast path: a DynamicCapture at time t as a SplatSet of the splats alive then.

Cost: one pass over the segment's splats in float32 for the opacity (a subtract, a multiply,
an exp), then gathers of the kept splats only. Arrays that need no change (scales, colours
and, when every splat is kept, the whole set) are read-only views of the capture's own.
bench/dynamic_bench.py measures it against np.argsort of as many depths.
"""
from __future__ import annotations

import numpy as np

from ..splats import SplatSet
from .capture import ALPHA_MIN, DynamicCapture, Frame

_F32 = np.float32


def _segment(capture: DynamicCapture, t: float) -> tuple[int, int, float]:
    k, local = capture.segment_at(t)
    return int(capture.segment_offsets[k]), int(capture.segment_offsets[k + 1]), local


def _opacity(capture: DynamicCapture, a: int, b: int, t: float):
    """(Delta (b-a,), opacity at t (b-a,), alive (b-a,) bool) in float32."""
    dt = np.subtract(_F32(t), capture.t_center[a:b])
    x = dt * capture.inverse_scale()[a:b]
    # 0 * inf (a zero width at Delta = 0) is the splat's own centre: full opacity
    nan = np.isnan(x)
    if nan.any():
        x[nan] = 0.0
    np.square(x, out=x)
    if capture.model == "4dgs":
        x *= _F32(-0.5)
    else:
        np.negative(x, out=x)
    marginal = np.exp(x, out=x)
    opacity = capture.opacities[a:b] * marginal
    alive = opacity >= _F32(ALPHA_MIN)
    if capture.model == "4dgs":
        alive &= marginal >= _F32(capture.cutoff)
        if capture.window is not None:
            lo, hi = capture.window[a:b, 0], capture.window[a:b, 1]
            alive &= (lo <= t) & (t < hi)
    return dt, opacity, alive


def alive_mask(capture: DynamicCapture, t: float) -> np.ndarray:
    a, b, local = _segment(capture, t)
    mask = np.zeros(capture.count, bool)
    with np.errstate(invalid="ignore", over="ignore"):
        mask[a:b] = _opacity(capture, a, b, local)[2]
    return mask


def _read_only(arr: np.ndarray) -> np.ndarray:
    view = arr.view()
    view.flags.writeable = False
    return view


def _centres(capture: DynamicCapture, rows, dt: np.ndarray) -> np.ndarray:
    """positions + sum_d motion[d] Delta^(d+1), by Horner's rule, float32."""
    motion = capture.motion[rows]
    d = dt[:, None]
    acc = motion[:, -1].copy()
    for term in range(motion.shape[1] - 2, -1, -1):
        acc *= d
        acc += motion[:, term]
    acc *= d
    acc += capture.positions[rows]
    return acc


def _rotations(capture: DynamicCapture, rows, dt: np.ndarray):
    """(unit quaternions, usable mask): rotations + omega Delta, normalised. Scaled by the
    largest component first, so neither a tiny nor a huge quaternion over- or underflows."""
    q = capture.rotations[rows]
    if capture.omega is not None:
        q = q + capture.omega[rows] * dt[:, None]
    else:
        q = q.copy()
    big = np.abs(q).max(axis=1)
    ok = (big > 0) & np.isfinite(big)
    q /= np.where(ok, big, _F32(1))[:, None]
    norm = np.sqrt(np.einsum("ij,ij->i", q, q))
    q /= np.where(ok, norm, _F32(1))[:, None]
    return q, ok


def evaluate(capture: DynamicCapture, t: float) -> Frame:
    # 0 * inf at a zero width is handled in _opacity; far-Delta overflow is counted below
    with np.errstate(invalid="ignore", over="ignore"):
        return _evaluate(capture, t)


def _evaluate(capture: DynamicCapture, t: float) -> Frame:
    a, b, local = _segment(capture, t)
    dt, opacity, alive = _opacity(capture, a, b, local)
    keep = np.flatnonzero(alive)
    everyone = keep.shape[0] == b - a
    rows = slice(a, b) if everyone else keep + a
    dtk = dt if everyone else dt[keep]
    centres = _centres(capture, rows, dtk)
    if capture.model == "4dgs":  # fixed orientation, unit since construction
        rotations, ok = capture.rotations[rows], None
        rotations = _read_only(rotations) if everyone else rotations
    else:
        rotations, ok = _rotations(capture, rows, dtk)
    finite = np.isfinite(centres).all(axis=1)
    good = finite if ok is None else finite & ok
    zero = 0 if ok is None else int(np.count_nonzero(~ok))
    pick = (lambda arr: _read_only(arr[rows])) if everyone else (lambda arr: arr[rows])
    splats = SplatSet(
        positions=centres, scales=pick(capture.scales), rotations=rotations,
        opacities=opacity if everyone else opacity[keep],
        sh_dc=pick(capture.sh_dc), sh_rest=pick(capture.sh_rest), axes=capture.axes)
    index = np.arange(a, b, dtype=np.int64) if everyone else keep.astype(np.int64) + a
    if not good.all():
        splats, index = splats.subset(good), index[good]
    return Frame(t=t, splats=splats, index=index, zero_rotations=zero,
                 overflow=int(np.count_nonzero(~finite)))


def rest_set(capture: DynamicCapture) -> SplatSet:
    """Every splat at Delta = 0 with its base opacity, in capture order (rotations
    normalised; a zero one becomes the identity, as the static readers' 'fix' does)."""
    q, ok = _rotations(capture, slice(None), np.zeros(capture.count, _F32))
    q[~ok] = (1.0, 0.0, 0.0, 0.0)
    return SplatSet(positions=capture.positions.copy(), scales=capture.scales.copy(),
                    rotations=q, opacities=capture.opacities.copy(), sh_dc=capture.sh_dc.copy(),
                    sh_rest=capture.sh_rest.copy(), axes=capture.axes)
