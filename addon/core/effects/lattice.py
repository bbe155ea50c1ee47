"""Where a set of splat centres falls in the noise lattice, computed once per set.

A noise field at fixed centres is a gather of 8 corner values per point and a weighted sum
with trilinear weights (noise.value_noise). The cell index and the 8 weights depend only
on the centres, the gizmo frame and the frequency, not on the seed, channel or layer, so
they are computed once (`LATTICES`, keyed like noise.FIELDS without seed and layer) and
every later field of those centres (the next Displace layer, a new seed) costs one gather
of 32 bytes a channel and one weighted sum per channel and point.

The weighted sum here is an einsum over (N, 8) rows, which numpy sums in a different order
from value_noise's einsum over (8, N) weights: values agree with it to a few float32 ulps
(tests/core/effects/test_effects_fast_paths.py pins them), and value_noise stays the readable
reference. (Not a matrix product: BLAS threads that spin while waiting for a core cost
more than they save on a busy machine.)
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .array_memo import ArrayMemo
from .common import F32, blocks, for_blocks, local_columns

BLOCK = 1 << 15      # points per block: a block's gathered corners stay in cache


@dataclass
class Lattice:
    index: np.ndarray     # (N,) intp: the wrapped cell of each point in the corner tables
    weights: np.ndarray   # (N, 8) float32: trilinear weights, corner k = dx*4 + dy*2 + dz

    def sample(self, tables: np.ndarray) -> np.ndarray:
        """(N, C) noise of C channels at these points; tables: (cells, C, 8) float32, each
        channel's noise.corner_table side by side, so one gather fetches every channel."""
        n = self.index.shape[0]
        out = np.empty((n, tables.shape[1]), F32)

        def block(part):
            rows = np.take(tables, self.index[part], axis=0)   # (block, C, 8)
            np.einsum("nck,nk->nc", rows, self.weights[part], out=out[part])

        for_blocks(n, block, BLOCK)
        return out


def cell(v: np.ndarray, period: int):
    """Integer cell index (wrapped) and the smoothed fraction of one coordinate column."""
    base = np.floor(v)
    frac = v - base
    frac *= frac * (F32(3.0) - F32(2.0) * frac)
    index = base.astype(np.intp)  # take() wants intp indices; int32 would be converted
    index &= period - 1
    return index, frac


def build(x: np.ndarray, y: np.ndarray, z: np.ndarray, period: int) -> Lattice:
    """The lattice geometry of points (x, y, z) in lattice units: noise.value_noise's
    cells and weights (noise._weights), written into one (N, 8) array."""
    n = x.shape[0]
    index = np.empty(n, np.intp)
    weights = np.empty((n, 8), F32)
    for part in blocks(n, BLOCK):
        ix, sx = cell(x[part], period)
        iy, sy = cell(y[part], period)
        iz, sz = cell(z[part], period)
        flat = index[part]
        np.multiply(ix, period, out=flat)
        flat += iy
        flat *= period
        flat += iz
        wx, wy, wz = (F32(1.0) - sx, sx), (F32(1.0) - sy, sy), (F32(1.0) - sz, sz)
        block = weights[part]
        for dy in (0, 1):
            for dz in (0, 1):
                yz = wy[dy] * wz[dz]
                for dx in (0, 1):
                    np.multiply(wx[dx], yz, out=block[:, dx * 4 + dy * 2 + dz])
    return Lattice(index, weights)


def _geometry(positions, frame, frequency, period) -> Lattice:
    cols = local_columns(positions, frame)
    for col in cols:
        col *= F32(frequency)
    lattice = build(cols[0], cols[1], cols[2], period)
    lattice.index.flags.writeable = False
    lattice.weights.flags.writeable = False
    return lattice


class LatticeCache:
    """Lattice geometry of splat centres, keyed by the positions array itself, the gizmo
    frame and the frequency. Each entry holds 36 bytes a splat, so only a few are kept."""

    def __init__(self, size: int = 2):
        self.memo = ArrayMemo(size)

    def get(self, positions: np.ndarray, frame: np.ndarray, frequency: float,
            period: int) -> Lattice:
        extra = (np.asarray(frame, np.float64).tobytes(), float(frequency), period)
        return self.memo.get((positions,), extra,
                             lambda: _geometry(positions, frame, frequency, period))

    def clear(self) -> None:
        self.memo.clear()


LATTICES = LatticeCache()
