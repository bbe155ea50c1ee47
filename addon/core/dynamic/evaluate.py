"""The float32 fast path: a DynamicCapture at time t as a SplatSet of the splats alive then.

Cost: contiguous float32 passes over the segment's splats (opacity, centres by Horner's rule
over the motion planes, rotations), then one compress per array to the kept splats. When
every splat is kept, the arrays that need no change (scales, colours) are read-only views of
the capture's own.
bench/dynamic_bench.py measures it against np.argsort of as many depths.
"""
from __future__ import annotations

import numpy as np

from ..splats import SplatSet
from .frame import ALPHA_MIN, Frame

# annotations name DynamicCapture (capture.py), which imports this module

_F32 = np.float32
_TINY = np.float32(np.finfo(np.float32).tiny)


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


def _centres(capture: DynamicCapture, rows: slice, dt: np.ndarray) -> np.ndarray:
    """positions + sum_d motion[d] Delta^(d+1), by Horner's rule, float32. motion[:, d] is a
    contiguous plane (capture.motion_planes), so each term is one pass."""
    motion = capture.motion[rows]
    d = dt[:, None]
    acc = motion[:, -1] * d
    for term in range(motion.shape[1] - 2, -1, -1):
        acc += motion[:, term]
        if term:
            acc *= d
    if motion.shape[1] > 1:
        acc *= d
    acc += capture.positions[rows]
    return acc


def _rotations(capture: DynamicCapture, rows: slice, dt: np.ndarray):
    """(unit quaternions, usable mask): rotations + omega Delta, normalised. A quaternion
    whose squared norm under- or overflows float32 is scaled by its largest component first."""
    q = capture.rotations[rows]
    q = q + capture.omega[rows] * dt[:, None] if capture.omega is not None else q.copy()
    norm2 = np.einsum("ij,ij->i", q, q)
    plain = (norm2 > _TINY) & (norm2 < np.inf)
    ok = plain.copy()
    odd = np.flatnonzero(~plain)
    if odd.size:  # rare: rescale those rows, then they normalise like the rest
        big = np.abs(q[odd]).max(axis=1)
        fine = (big > 0) & np.isfinite(big)
        q[odd[fine]] /= big[fine, None]
        ok[odd[fine]] = True
        norm2[odd] = np.einsum("ij,ij->i", q[odd], q[odd])
    norm = np.sqrt(norm2, out=norm2)
    norm[~ok] = 1.0
    q /= norm[:, None]
    return q, ok


def _finite_rows(arr: np.ndarray) -> np.ndarray:
    """Rows without NaN/inf: their sum is finite (a sum that overflows flags a centre
    within a factor 3 of float32's limit, which the renderer could not use anyway)."""
    total = arr[:, 0] + arr[:, 1]
    total += arr[:, 2]
    return np.isfinite(total)


def evaluate(capture: DynamicCapture, t: float) -> Frame:
    # 0 * inf at a zero width is handled in _opacity; far-Delta overflow is counted below
    with np.errstate(invalid="ignore", over="ignore"):
        return _evaluate(capture, t)


def _evaluate(capture: DynamicCapture, t: float) -> Frame:
    """Centres and rotations of the whole segment (contiguous passes), then one compress of
    each array to the kept splats: cheaper than gathering inputs when most are alive."""
    a, b, local = _segment(capture, t)
    rows = slice(a, b)
    dt, opacity, alive = _opacity(capture, a, b, local)
    centres = _centres(capture, rows, dt)
    finite = _finite_rows(centres)
    if capture.model == "4dgs":  # fixed orientation, unit since construction
        rotations, ok = capture.segment_view("rotations", a, b), None
    else:
        rotations, ok = _rotations(capture, rows, dt)
    zero = 0 if ok is None else int(np.count_nonzero(alive & ~ok))
    overflow = int(np.count_nonzero(alive & ~finite))
    good = alive & finite if ok is None else alive & finite & ok
    if good.all():
        pick = lambda name: capture.segment_view(name, a, b)
        index = np.arange(a, b, dtype=np.int64)
    else:
        pick = lambda name: np.compress(good, getattr(capture, name)[rows], axis=0)
        index = np.flatnonzero(good).astype(np.int64) + a
        centres, rotations, opacity = (np.compress(good, x, axis=0) for x in (centres, rotations, opacity))
    splats = SplatSet(positions=centres, scales=pick("scales"), rotations=rotations, opacities=opacity,
                      sh_dc=pick("sh_dc"), sh_rest=pick("sh_rest"), axes=capture.axes)
    return Frame(t=t, splats=splats, index=index, zero_rotations=zero, overflow=overflow)


def rest_set(capture: DynamicCapture) -> SplatSet:
    """Every splat at Delta = 0 with its base opacity, in capture order (rotations
    normalised; a zero one becomes the identity, as the static readers' 'fix' does)."""
    with np.errstate(invalid="ignore", over="ignore"):
        q, ok = _rotations(capture, slice(None), np.zeros(capture.count, _F32))
    q[~ok] = (1.0, 0.0, 0.0, 0.0)
    return SplatSet(positions=capture.positions.copy(), scales=capture.scales.copy(),
                    rotations=q, opacities=capture.opacities.copy(), sh_dc=capture.sh_dc.copy(),
                    sh_rest=capture.sh_rest.copy(), axes=capture.axes)
