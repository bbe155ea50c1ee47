"""The percentile box of the splats that show, for framing a capture (framing.Bounds).

Real captures carry a sparse, faint halo: splats too faint or too far apart to show, spread
several times wider than the subject. A percentile box over every centre (robust_bounds)
takes them in, and the subject ends up at half the frame. Here a splat counts only where
the splats round it add up to a visible alpha, seen along each world axis: a coarse
orthographic alpha pass, no renderer needed. Each splat adds its optical depth
-log(1 - opacity), spread over its cell in proportion to its footprint (2 pi times its two
largest scales: a Gaussian's integral) when that is smaller than the cell; a cell's alpha
is 1 - exp(-sum); a splat wider than a cell adds its depth at the level of a pyramid of
cells (each twice the one below) whose cells hold it, so large splats that overlap add up.
A splat is kept when its cell's alpha reaches COVER in all three views (a visual hull of
the three silhouettes), and the usual 2nd-98th percentile box is taken over the kept
centres. So what counts is what covers a cell at the scale of the subject (a 64th of its
box): a solid surface, a haze, a single opaque splat as large as a cell; not a sparse halo
of faint splats, nor a few opaque specks far smaller than a cell (floaters, which the
percentiles trim as before). Alpha along a line of sight does not depend on the splats'
order, so no sort is needed.

Two passes: the first over the wide box of the centres (0.5th-99.5th percentiles), whose
cells are coarse when the halo is wide; the second over the first pass's box with room
round it, at the subject's own scale. A strided sample of at most SAMPLE splats stands in
for a larger capture (each weighs for the splats it stands for): the box moves by well
under a cell, and a million-splat import spends a few tens of milliseconds here.
"""
from __future__ import annotations

import math

import numpy as np

from .framing import Bounds, robust_bounds

SAMPLE = 1 << 17
CELLS = 64  # along the box's longest side
COVER = 0.5  # a cell's alpha at which its splats show
WIDE = (0.5, 99.5)  # the first pass's box: far floaters left out
ROOM = (0.05, 0.25)  # each pass's grid reaches this much of the box's longest side beyond it
MIN_SHOWN = 16  # fewer kept than this (a capture with nothing solid): every centre counts
MAX_DEPTH = -math.log(1.0 - 0.999)  # one splat's optical depth: opacity 1 is not infinite


def visible_bounds(points, opacities, scales) -> Bounds:
    """The 2nd-98th percentile box of the centres of the splats that show. points: (N, 3)
    world centres; opacities: (N,); scales: (N, 3) world-scaled (linear, not log)."""
    pts, depth, footprint, reach = _sample(points, opacities, scales)
    if len(pts) < MIN_SHOWN:
        return robust_bounds(points)
    box = robust_bounds(pts, *WIDE)
    kept = None
    for room in ROOM:
        pad = room * float((box.high - box.low).max())
        kept = shown(pts, depth, footprint, reach, box.low - pad, box.high + pad)
        if np.count_nonzero(kept) < MIN_SHOWN:
            return robust_bounds(points)
        box = robust_bounds(pts[kept])
    return box


def _sample(points, opacities, scales):
    """The finite splats of a strided sample: centres, optical depth (weighted by the stride),
    footprint area and reach (the largest scale)."""
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    stride = max(1, -(-len(pts) // SAMPLE))
    pts = pts[::stride]
    alpha = np.nan_to_num(np.asarray(opacities, np.float64)[::stride], nan=0.0)
    s = np.abs(np.nan_to_num(np.asarray(scales, np.float64).reshape(-1, 3)[::stride], nan=0.0))
    large, small = s.max(axis=1), s.min(axis=1)
    footprint = 2.0 * math.pi * large * (s.sum(axis=1) - large - small)
    depth = stride * np.minimum(-np.log1p(-np.clip(alpha, 0.0, 0.999)), MAX_DEPTH)
    finite = np.isfinite(pts[:, 0]) & np.isfinite(pts[:, 1]) & np.isfinite(pts[:, 2])
    if finite.all():
        return pts, depth, footprint, large
    return pts[finite], depth[finite], footprint[finite], large[finite]


def shown(pts, depth, footprint, reach, low, high, cells=CELLS, cover=COVER) -> np.ndarray:
    """Whether each splat's cell reaches alpha `cover` in each of the three axis views of a
    grid of cubic cells over [low, high] (`cells` along its longest side); splats outside
    the grid are not shown. A splat wider than a cell adds its depth at the level of a
    pyramid of cells (each twice the one below) whose cells hold it, so large splats that
    overlap add up; a cell's alpha counts every level above it."""
    extent = np.maximum(high - low, 1e-12)
    cell = float(extent.max()) / cells
    dims = np.maximum(np.ceil(extent / cell).astype(np.int64), 1)
    ijk = np.floor((pts - low) / cell).astype(np.int64)
    kept = (ijk[:, 0] >= 0) & (ijk[:, 0] < dims[0])
    for c in (1, 2):  # a column at a time: numpy's reduction along rows of 3 is slow
        kept &= (ijk[:, c] >= 0) & (ijk[:, c] < dims[c])
    index = np.flatnonzero(kept)
    ijk = ijk[index]
    top = max(0, math.ceil(math.log2(cells)))
    level = np.clip(np.ceil(np.log2(np.maximum(2.0 * reach[index] / cell, 1.0))), 0, top).astype(np.int64)
    weight = depth[index] * np.minimum(1.0, footprint[index] / (cell * np.exp2(level)) ** 2)
    needed = -math.log(1.0 - cover)
    steps = [(int(step), level == step) for step in np.flatnonzero(np.bincount(level))]
    for a, b in ((1, 2), (0, 2), (0, 1)):  # looking along x, y and z
        seen = np.zeros(len(index))
        for step, here in steps:
            rows = -(-dims[b] // (1 << step))
            at = (ijk[:, a] >> step) * rows + (ijk[:, b] >> step)
            view = np.bincount(at[here], weights=weight[here], minlength=int((dims[a] >> step) + 1) * rows)
            seen += view[at]
        kept[index] &= seen >= needed
    return kept
