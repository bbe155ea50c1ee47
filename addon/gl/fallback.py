"""GL 3.3 fallback (no compute shaders, e.g. macOS's OpenGL 4.1): preprocess and sort
on the CPU, draw on the GPU.

The projection is core/preprocess.py's (float64, camera-relative), the order is
core.sort.back_to_front with the same quantised keys, and the records go to the GPU in
back-to-front order as RGBA32F textures (shaders/gl_records_texture.glsl) for the same
draw and depth-pass shaders. Records depend on the camera, so they are sent every frame.
Equirect cameras: the seam copies are appended as extra records, as the reference does.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..core import stop
from ..core.equirect import seam_shifts
from ..core.preprocess import project
from ..core.sort import back_to_front
from .shaders import RECORD_WIDTH

RECORD_UNITS = (4, 5, 6)  # texture units of u_rec0..2 (0..2 belong to the depth pass)
_BLOCK = 1 << 21          # splats a projection step


def cpu_records(items, camera, options) -> tuple[np.ndarray, int]:
    """(3, V, 4) float32 records of the visible splats, back to front, and V."""
    recs = [_item_records(item, camera, options) for item in items]
    if not recs:
        return np.zeros((3, 0, 4), np.float32), 0
    rec = np.concatenate(recs, axis=1)
    if camera.equirect:
        rec = _with_seam_copies(rec, camera)
    u, v, r = rec[0, :, 0], rec[0, :, 1], rec[1, :, 1]
    with np.errstate(invalid="ignore"):
        on = (u + r >= 0) & (u - r <= camera.width) & (v + r >= 0) & (v - r <= camera.height)
    depth = np.where(on, rec[1, :, 2], np.inf)
    order = back_to_front(depth, options.key_bits, np.isfinite(depth))
    return _gathered(rec, order), int(order.size)


def _gathered(rec: np.ndarray, order: np.ndarray) -> np.ndarray:
    """rec[:, order] as float32, a block at a time: no float64 copy of the whole gather, and
    a stop seen between blocks (10M splats' gather took 10 s here)."""
    out = np.empty((3, order.size, 4), np.float32)
    for start in range(0, order.size, _BLOCK):
        stop.check()
        out[:, start:start + _BLOCK] = rec[:, order[start:start + _BLOCK]]
    return out


def _item_records(item, camera, options) -> np.ndarray:
    """(3, N, 4) float64 records of one item; culled splats have depth +inf. A large item is
    projected a block at a time, a stop seen between blocks (10M splats in one call took
    17 s to answer a SIGTERM); the projection is per splat, so the records are the same."""
    n = item.splats.count
    if n <= _BLOCK:
        return _block_records(item, camera, options)
    parts = []
    for start in range(0, n, _BLOCK):
        stop.check()
        block = item.splats.subset(np.arange(start, min(n, start + _BLOCK)))
        parts.append(_block_records(replace(item, splats=block), camera, options))
    return np.concatenate(parts, axis=1)


def _block_records(item, camera, options) -> np.ndarray:
    p = project(item, camera, options.antialiased, options.capped_extent)
    rec = np.zeros((3, item.splats.count, 4))
    rec[0] = np.stack([p.means2d[:, 0], p.means2d[:, 1], p.conic[:, 0], p.conic[:, 1]], 1)
    rec[1] = np.stack([p.conic[:, 2], p.radius, np.where(p.valid, p.depth, np.inf), p.opacity], 1)
    rec[2, :, :3] = p.rgb
    return rec


def _with_seam_copies(rec: np.ndarray, camera) -> np.ndarray:
    """The records plus each seam copy (after all originals), shifted by a period."""
    parts = [rec]
    for idx, shift in seam_shifts(rec[0, :, 0], rec[1, :, 1], camera):
        copy = rec[:, idx].copy()
        copy[0, :, 0] += shift
        parts.append(copy)
    return np.concatenate(parts, axis=1)


class RecordTextures:
    """Three RGBA32F textures RECORD_WIDTH wide, grown as needed."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.rows = 0
        self.textures = []

    def upload(self, records: np.ndarray, stats: dict):
        n = records.shape[1]
        rows = max(1, -(-n // RECORD_WIDTH))
        if rows > self.rows:
            self.release()
            self.textures = [self.ctx.texture((RECORD_WIDTH, rows), 4, dtype="f4") for _ in range(3)]
            self.rows = rows
        padded = np.zeros((3, rows * RECORD_WIDTH, 4), np.float32)
        padded[:, :n] = records
        for tex, data in zip(self.textures, padded):
            tex.write(data.tobytes(), viewport=(0, 0, RECORD_WIDTH, rows))
        stats["bytes_uploaded"] += padded.nbytes

    def bind(self, *programs):
        for unit, tex in zip(RECORD_UNITS, self.textures):
            tex.use(unit)
        for prog in programs:
            for name, unit in zip(("u_rec0", "u_rec1", "u_rec2"), RECORD_UNITS):
                if name in prog:
                    prog[name].value = unit

    def release(self):
        for tex in self.textures:
            tex.release()
        self.textures = []
        self.rows = 0
