"""The pos and shape textures' CPU copies, kept between frames and rewritten only where
their sources changed (no bpy, no gpu).

An effect playing hands the viewport new arrays every frame, but often only some of
them: a fade or reveal makes new opacities and keeps the positions array, a displace
makes new positions. The stream (packing.pack_pos's layout: xyz, opacity or NaN where
packing.drawable says no) is rewritten in place per object and per part, and `update`
says what the GPU needs: nothing, the alpha channel alone, or the whole texture.
"""
from __future__ import annotations

import numpy as np

from . import packing
from .packing import padded

NOTHING, ALPHA, ALL = 0, 1, 2


class PosStage:
    def __init__(self):
        self.flat: np.ndarray | None = None   # (padded(total), 4) float32
        self.alpha: np.ndarray | None = None  # (padded(total),) float32: flat[:, 3], contiguous
        self.counts: tuple = ()
        self.sources: list = []  # per object: ((positions key, positions), (key, opacities, valid))

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in (self.flat, self.alpha) if a is not None)

    def update(self, parts: list[tuple]) -> int:
        """parts: per object (positions key, positions, key, opacities, valid). Returns
        NOTHING, ALPHA (only opacities changed: self.alpha holds the new channel) or ALL."""
        counts = tuple(p[1].shape[0] for p in parts)
        fresh = self.flat is None or counts != self.counts
        if fresh:
            self.flat = np.zeros((padded(sum(counts)), 4), np.float32)
            self.counts, self.sources = counts, [None] * len(parts)
        moved = faded = False
        start = 0
        for k, (positions_key, positions, key, opacities, valid) in enumerate(parts):
            n = positions.shape[0]
            old = self.sources[k]
            rows = self.flat[start:start + n]
            if old is None or not _same(old[0], (positions_key, positions)):
                for axis in range(3):  # a column at a time: 3.5x faster than rows[:, :3] = ...
                    rows[:, axis] = positions[:, axis]
                moved = True
            if old is None or not _same(old[1], (key, opacities, valid)):
                column = rows[:, 3]
                np.copyto(column, opacities)
                column[~valid] = np.nan  # not drawable: the shader's validity mark
                faded = True
            self.sources[k] = ((positions_key, positions), (key, opacities, valid))
            start += n
        if fresh or moved:
            return ALL
        if not faded:
            return NOTHING
        if self.alpha is None or self.alpha.size != self.flat.shape[0]:
            self.alpha = np.empty(self.flat.shape[0], np.float32)
        np.copyto(self.alpha, self.flat[:, 3])
        return ALPHA


def _same(old: tuple, new: tuple) -> bool:
    """Equal keys and the very same arrays (`is`): a new geometry version under the same
    arrays (edited in place) has a new key."""
    return old[0] == new[0] and all(a is b for a, b in zip(old[1:], new[1:]))


class ShapeStage:
    """The shape stream (packing.pack_shape's layout: rotation, scales, SH DC; SHAPE_VALUES
    a splat) kept between frames: a colour effect rewrites the DC columns alone, a size
    effect the scales (with the rotation part's kept largest-component index)."""

    def __init__(self):
        self.flat: np.ndarray | None = None
        self.counts: tuple = ()
        self.sources: list = []  # per object: (rotations, scales, sh_dc) as (key, array)
        self.largest: list = []  # per object: the dropped quaternion component's index

    @property
    def nbytes(self) -> int:
        return 0 if self.flat is None else self.flat.nbytes + sum(a.nbytes for a in self.largest)

    def update(self, parts: list[tuple]) -> bool:
        """parts: per object ((key, rotations), (key, scales), (key, sh_dc)). Returns
        whether the stream changed (the texture needs uploading)."""
        counts = tuple(p[0][1].shape[0] for p in parts)
        if self.flat is None or counts != self.counts:
            self.flat = packing.stream(sum(counts) * packing.SHAPE_VALUES)
            self.counts, self.sources, self.largest = counts, [None] * len(parts), [None] * len(parts)
        changed, start = False, 0
        for k, part in enumerate(parts):
            n = counts[k]
            view = self.flat.reshape(-1)[start * packing.SHAPE_VALUES:(start + n) * packing.SHAPE_VALUES]
            view = view.reshape(n, packing.SHAPE_VALUES)
            old = self.sources[k] or (None, None, None)
            rotation, size, colour = (o is None or not _same(o, p) for o, p in zip(old, part))
            if rotation:
                three, largest = packing.shape_rotation(part[0][1])
                self.largest[k] = largest
                _columns(view, 0, three)
            if rotation or size:
                packing.halves_into(view[:, 3:6], part[1][1], self.largest[k])
            if colour:
                packing.halves_into(view[:, 6:9], part[2][1])
            changed |= rotation or size or colour
            self.sources[k] = part
            start += n
        return changed


def _columns(view: np.ndarray, first: int, values: np.ndarray) -> None:
    for c in range(values.shape[1]):  # a column at a time: several times faster than a block
        view[:, first + c] = values[:, c]
