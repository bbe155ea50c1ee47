"""Back-to-front ordering with fixed-point depth keys.

Keys are quantized over the depth range of the splats actually in view, not a
fixed range, so 16 bits stay useful for a capture 1 m deep seen from 1 km away.
numpy's stable argsort on uint16/uint32 keys is a radix sort.
"""
from __future__ import annotations

import numpy as np


def depth_keys(depth: np.ndarray, bits: int = 32, visible: np.ndarray | None = None) -> np.ndarray:
    """Keys that order far-to-near: key 0 is the farthest visible depth.

    depth    view-space depth (-z, larger is farther), any float dtype
    visible  optional mask; the range comes from visible, finite depths only.
             Hidden or non-finite entries get the largest key (drawn last, and
             the caller is expected to skip them anyway).
    """
    if bits not in (16, 32):
        raise ValueError(f"key bits must be 16 or 32, not {bits}")
    dtype = np.uint16 if bits == 16 else np.uint32
    top = np.iinfo(dtype).max
    d = np.asarray(depth, np.float64)
    ok = np.isfinite(d) if visible is None else (visible & np.isfinite(d))
    keys = np.full(d.shape, top, dtype)
    if not ok.any():
        return keys
    lo, hi = d[ok].min(), d[ok].max()
    span = hi - lo
    # Multiply in float64 and clip before the integer cast: no overflow for any span.
    scale = (top - 1) / span if span > 0 else 0.0
    keys[ok] = np.clip((hi - d[ok]) * scale, 0, top - 1).astype(dtype)
    return keys


def back_to_front(depth: np.ndarray, bits: int = 32, visible: np.ndarray | None = None) -> np.ndarray:
    """Indices of the visible splats, farthest first (stable within a key)."""
    keys = depth_keys(depth, bits, visible)
    order = np.argsort(keys, kind="stable")
    if visible is not None:
        order = order[visible[order]]
    else:
        order = order[np.isfinite(np.asarray(depth)[order])]
    return order.astype(np.uint32)
