"""Pinning DynamicCapture.at (float32) to reference_at (float64), and to fourdgs' state_at, at one time."""
from __future__ import annotations

import numpy as np

from addon.core.dynamic import ALPHA_MIN, reference_at

from .dynamic_captures import same_rotation


def _near_threshold(capture, ref_opacity_of, index, t) -> np.ndarray:
    """Which of `index` sit within float32 rounding of a keep/drop threshold at t."""
    op = ref_opacity_of(index)
    near = np.abs(op - ALPHA_MIN) <= 1e-5 * ALPHA_MIN
    if capture.model == "4dgs":
        k, local = capture.segment_at(t)
        delta = local - capture.t_center[index].astype(np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            marginal = np.exp(-0.5 * (delta / capture.t_scale[index].astype(np.float64)) ** 2)
        near |= np.abs(marginal - capture.cutoff) <= 1e-5 * capture.cutoff
    return near


def full_opacity(capture, t):
    """float64 opacity at t of every splat in t's segment, by capture index (NaN elsewhere)."""
    k, local = capture.segment_at(t)
    a, b = capture.segment_offsets[k], capture.segment_offsets[k + 1]
    out = np.full(capture.count, np.nan)
    delta = local - capture.t_center[a:b].astype(np.float64)
    width = capture.t_scale[a:b].astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(delta == 0, 0.0, delta / width)
    factor = np.exp(-0.5 * ratio ** 2) if capture.model == "4dgs" else np.exp(-ratio ** 2)
    out[a:b] = capture.opacities[a:b] * factor
    return out


def check_against_reference(capture, t) -> tuple:
    """Assert at(t) equals reference_at(t) to float32 rounding; returns (frame, reference)."""
    frame, ref = capture.at(t), reference_at(capture, t)
    frame.splats.check()
    assert np.all(np.diff(frame.index) > 0)
    opacity = full_opacity(capture, t)
    differ = np.setxor1d(frame.index, ref.index)
    assert _near_threshold(capture, lambda i: opacity[i], differ, t).all(), (
        f"t={t}: {differ.size} splats kept by one path only, away from the thresholds")
    common, fi, ri = np.intersect1d(frame.index, ref.index, return_indices=True)
    assert common.size >= min(frame.alive, ref.index.size) - differ.size
    pos, rpos = frame.splats.positions[fi].astype(np.float64), ref.positions[ri]
    scale = np.abs(capture.positions[common]).max(axis=1) + np.abs(capture.motion[common]).sum(axis=(1, 2)) * \
        np.maximum(1.0, np.abs(capture.segment_at(t)[1] - capture.t_center[common].astype(np.float64))) ** \
        capture.motion.shape[1]
    assert np.all(np.abs(pos - rpos).max(axis=1) <= 64 * np.finfo(np.float32).eps * np.maximum(scale, 1.0))
    assert np.all(same_rotation(frame.splats.rotations[fi].astype(np.float64), ref.rotations[ri]) <= 2e-6)
    np.testing.assert_allclose(frame.splats.opacities[fi], ref.opacities[ri], rtol=2e-6, atol=1e-7)
    assert np.isfinite(frame.splats.positions).all() and np.isfinite(frame.splats.rotations).all()
    return frame, ref


def fourdgs_state_matches(capture, state, t):
    """Splatline's at(t) equals fourdgs' state_at(t) on the splats both keep; fourdgs keeps
    the rest only below Splatline's opacity floor of 1/255."""
    frame = capture.at(t)
    theirs = np.asarray(state["indices"])
    assert set(frame.index) <= set(theirs)
    extra = np.setdiff1d(theirs, frame.index)
    assert np.all(np.asarray(state["opacity"])[np.searchsorted(theirs, extra)] < ALPHA_MIN * (1 + 1e-5))
    rows = np.searchsorted(theirs, frame.index)
    centres = np.asarray(state["centers"])[rows]
    tol = 8 * np.finfo(np.float32).eps * (np.abs(centres) + np.abs(capture.motion[frame.index, 0]).sum(1)[:, None]
                                          * max(1.0, abs(t)) + 1.0)
    assert np.all(np.abs(frame.splats.positions - centres) <= tol)
    xyzw = np.asarray(state["orientations"])[rows]
    assert same_rotation(frame.splats.rotations.astype(np.float64), xyzw[:, [3, 0, 1, 2]]).max() <= 1e-6
    np.testing.assert_allclose(frame.splats.opacities, np.asarray(state["opacity"])[rows], rtol=2e-6, atol=1e-8)
    return frame.alive
