"""Seeded, smooth 3D value noise in plain numpy, periodic every PERIOD lattice cells.

Each lattice cell stores its 8 corner values side by side (one 32-byte row), so one gather
per channel fetches all corners; the trilinear weights (cubic-smoothed, so the noise is C1)
are shared by every channel. Output is in [-1, 1], a pure function of (point, seed, channel,
layer); layers are independent fields (Displace blends consecutive layers over time).

`field` memoizes the noise at a set of splat centres (the same positions array, gizmo frame,
frequency, seed and layer give the same values), so a field that does not move costs a
lookup on later frames. The memo is bounded and never changes a result.
"""
from __future__ import annotations

import threading
from collections import OrderedDict

import numpy as np

from .array_memo import ArrayMemo, read_only
from .common import F32, local_columns
from .lattice import LATTICES, cell

PERIOD = 32          # lattice cells before the pattern repeats (a power of two)
_MASK = PERIOD - 1
_MAX_TABLES = 48     # 1 MB each
_TABLES: OrderedDict = OrderedDict()   # pure cache: (seed, stream) -> corner table
_LOCK = threading.Lock()


def _table(key, make) -> np.ndarray:
    """_TABLES' read-only array for key, made by make() on a miss."""
    table = _TABLES.get(key)
    if table is None:
        table = make()
        table.flags.writeable = False
        with _LOCK:
            _TABLES[key] = table
            while len(_TABLES) > _MAX_TABLES:
                _TABLES.popitem(last=False)
    return table


def corner_table(seed: int, channel: int, layer: int = 0) -> np.ndarray:
    return _table((seed, channel, layer), lambda: _make_corner_table(seed, channel, layer))


def _make_corner_table(seed: int, channel: int, layer: int) -> np.ndarray:
    stream = (layer * 8 + channel) % (1 << 40)
    rng = np.random.default_rng([seed & 0xFFFFFFFF, 7919 + stream])
    lattice = rng.uniform(-1.0, 1.0, (PERIOD,) * 3).astype(F32)
    corners = np.empty((PERIOD,) * 3 + (8,), F32)
    for k in range(8):
        dx, dy, dz = k >> 2, (k >> 1) & 1, k & 1
        corners[..., k] = np.roll(lattice, (-dx, -dy, -dz), axis=(0, 1, 2))
    return np.ascontiguousarray(corners.reshape(-1, 8))


def lattice_value(seed: int, channel: int, i: int, j: int, k: int) -> float:
    """The noise value at an integer lattice point (for tests)."""
    table = corner_table(seed, channel)
    return float(table[((i & _MASK) * PERIOD + (j & _MASK)) * PERIOD + (k & _MASK), 0])


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
                channels: int = 1, layer: int = 0, block: int = 1 << 16) -> list[np.ndarray]:
    """`channels` independent noise values at the points (x, y, z) in lattice units.

    Evaluated `block` points at a time: the ~20 temporaries of a block (weights, corners,
    indices) stay in cache and their memory is reused, instead of streaming ~200 MB of
    fresh arrays per million points through RAM."""
    x, y, z = (np.asarray(c, F32) for c in (x, y, z))
    n = x.shape[0]
    tables = [corner_table(seed, c, layer) for c in range(channels)]
    out = [np.empty(n, F32) for _ in range(channels)]
    for start in range(0, n, block):
        part = slice(start, start + block)
        ix, sx = cell(x[part], PERIOD)
        iy, sy = cell(y[part], PERIOD)
        iz, sz = cell(z[part], PERIOD)
        index = ix * PERIOD
        index += iy
        index *= PERIOD
        index += iz
        weights = _weights(sx, sy, sz)
        for table, values in zip(tables, out):
            corners = np.take(table, index, axis=0)  # (block, 8), one row per point
            np.einsum("kn,nk->n", weights, corners, out=values[part])
    return out


class FieldCache:
    """Noise values at splat centres, keyed by the positions array itself, the gizmo frame,
    frequency, seed, layer and channel count. Values are read-only (N, channels) arrays:
    a Displace blend then works on contiguous rows."""

    def __init__(self, size: int = 8):
        self.memo = ArrayMemo(size)

    def get(self, positions: np.ndarray, frame: np.ndarray, frequency: float, seed: int,
            channels: int, layer: int = 0) -> np.ndarray:
        extra = (np.asarray(frame, np.float64).tobytes(), float(frequency), seed, channels, layer)
        return self.memo.get((positions,), extra, lambda: read_only(
            evaluate_rows(positions, frame, frequency, seed, channels, layer)))

    def clear(self) -> None:
        self.memo.clear()


def evaluate_rows(positions, frame, frequency, seed, channels, layer=0) -> np.ndarray:
    """Noise at the gizmo-local centres times frequency, (N, channels) (no memo of the
    values; the centres' lattice geometry is memoized in lattice.LATTICES, shared by every
    layer). The channels' corner tables side by side: one gather per point for all."""
    lattice = LATTICES.get(positions, frame, frequency, PERIOD)
    return lattice.sample(corner_tables(seed, channels, layer))


def corner_tables(seed: int, channels: int, layer: int = 0) -> np.ndarray:
    """(cells, channels, 8): the channels' corner tables side by side (memoized with them)."""
    return _table((seed, "channels", channels, layer), lambda: np.stack(
        [corner_table(seed, c, layer) for c in range(channels)], axis=1))


def evaluate_field(positions, frame, frequency, seed, channels, layer=0) -> list[np.ndarray]:
    """evaluate_rows as one (N,) array per channel."""
    rows = evaluate_rows(positions, frame, frequency, seed, channels, layer)
    return [rows[:, c] for c in range(channels)]


def reference_field(positions, frame, frequency, seed, channels, layer=0) -> list[np.ndarray]:
    """evaluate_field through value_noise: the readable maths the fast path is pinned to."""
    cols = local_columns(positions, frame)
    f = F32(frequency)
    for col in cols:
        col *= f
    return value_noise(cols[0], cols[1], cols[2], seed, channels, layer)


FIELDS = FieldCache()


def rest_field(splats, rest, p) -> np.ndarray:
    """The one-channel noise field of effect params p (frame, frequency, seed) at the splats'
    rest centres (rest: None where the stack has none for these splats: their own)."""
    return field(splats.positions if rest is None else rest, p.frame, p.frequency, p.seed)[0]


def field(positions, frame, frequency, seed, channels=1, layer=0) -> list[np.ndarray]:
    """Memoized noise at splat centres: read-only (N,) float32 arrays, one per channel."""
    rows = field_rows(positions, frame, frequency, seed, channels, layer)
    return [rows[:, c] for c in range(channels)]


def field_rows(positions, frame, frequency, seed, channels=1, layer=0) -> np.ndarray:
    """Memoized noise at splat centres: one read-only (N, channels) float32 array."""
    return FIELDS.get(positions, frame, frequency, seed, channels, layer)
