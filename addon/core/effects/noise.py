"""Seeded, smooth 3D value noise in plain numpy, periodic every PERIOD lattice cells.

Each lattice cell stores its 8 corner values side by side (32 bytes), so one gather per
channel fetches all corners; the trilinear weights (cubic-smoothed, so the noise is C1)
are shared by every channel. Output is in [-1, 1], a pure function of (point, seed, channel).
"""
from __future__ import annotations

import numpy as np

from .common import F32

PERIOD = 32          # lattice cells before the pattern repeats (a power of two)
_MASK = PERIOD - 1
_CORNER = np.dtype((np.void, 32))
_TABLES: dict = {}   # pure cache: (seed, channel) -> corner table


def corner_table(seed: int, channel: int) -> np.ndarray:
    key = (seed, channel)
    table = _TABLES.get(key)
    if table is None:
        rng = np.random.default_rng([seed & 0xFFFFFFFF, 7919 + channel])
        lattice = rng.uniform(-1.0, 1.0, (PERIOD,) * 3).astype(F32)
        corners = np.empty((PERIOD,) * 3 + (8,), F32)
        for k in range(8):
            dx, dy, dz = k >> 2, (k >> 1) & 1, k & 1
            corners[..., k] = np.roll(lattice, (-dx, -dy, -dz), axis=(0, 1, 2))
        table = corners.reshape(-1, 8).view(_CORNER).ravel()
        _TABLES[key] = table
    return table


def lattice_value(seed: int, channel: int, i: int, j: int, k: int) -> float:
    """The noise value at an integer lattice point (for tests)."""
    table = corner_table(seed, channel).view(F32).reshape(-1, 8)
    return float(table[((i & _MASK) * PERIOD + (j & _MASK)) * PERIOD + (k & _MASK), 0])


def _cell(v: np.ndarray):
    """Integer cell index (wrapped) and the smoothed fraction of one coordinate column."""
    base = np.floor(v)
    frac = v - base
    frac *= frac * (F32(3.0) - F32(2.0) * frac)
    index = base.astype(np.int32)
    index &= _MASK
    return index, frac


def _weights(sx, sy, sz) -> np.ndarray:
    """(8, N) trilinear weights, corner k = dx*4 + dy*2 + dz; contiguous rows are written
    far faster than the strided columns of an (N, 8) array."""
    n = sx.shape[0]
    wx = (F32(1.0) - sx, sx)
    wy = (F32(1.0) - sy, sy)
    wz = (F32(1.0) - sz, sz)
    weights = np.empty((8, n), F32)
    for dy in (0, 1):
        for dz in (0, 1):
            yz = wy[dy] * wz[dz]
            for dx in (0, 1):
                np.multiply(wx[dx], yz, out=weights[dx * 4 + dy * 2 + dz])
    return weights


def value_noise(x: np.ndarray, y: np.ndarray, z: np.ndarray, seed: int,
                channels: int = 1) -> list[np.ndarray]:
    """`channels` independent noise values at the points (x, y, z) in lattice units."""
    x, y, z = (np.asarray(c, F32) for c in (x, y, z))
    ix, sx = _cell(x)
    iy, sy = _cell(y)
    iz, sz = _cell(z)
    index = ix * PERIOD
    index += iy
    index *= PERIOD
    index += iz
    weights = _weights(sx, sy, sz)
    out = []
    for c in range(channels):
        corners = np.take(corner_table(seed, c), index).view(F32).reshape(-1, 8)
        out.append(np.einsum("kn,nk->n", weights, corners))
    return out
