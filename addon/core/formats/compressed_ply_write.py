"""PlayCanvas / SuperSplat compressed .ply writer: the inverse of compressed_ply.py's packing
(see there for the bit layout). Splats are written in Morton order of their positions, as
splat-transform does: a 256-splat chunk then covers a small box, so the 11/10/11-bit
positions inside the chunk's bounds are fine steps rather than slices of the whole scene.
"""
from __future__ import annotations

import numpy as np

from ..sh import C0
from ..splats import SplatSet
from ._common import clamp_note, write_file
from .compressed_ply import BOUNDS, CHUNK, COLOR_BOUNDS
from .ply import ANTIALIASED_COMMENT, rest_names


def _morton_order(p: np.ndarray) -> np.ndarray:
    lo, hi = p.min(axis=0), p.max(axis=0)
    q = ((p - lo) / np.where(hi > lo, hi - lo, 1) * 1023).astype(np.uint64)
    code = np.zeros(len(p), np.uint64)
    for bit in range(10):
        for axis in range(3):
            code |= ((q[:, axis] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(3 * bit + axis)
    return np.argsort(code, kind="stable")


def _chunk_bounds(v: np.ndarray, n_chunks: int):
    pad = np.concatenate([v, np.repeat(v[-1:], n_chunks * CHUNK - len(v), axis=0)])
    blocks = pad.reshape(n_chunks, CHUNK, -1)
    return blocks.min(axis=1), blocks.max(axis=1)


def _unorm(v, lo, hi, bits: int) -> np.ndarray:
    top = (1 << bits) - 1
    t = (v - lo) / np.where(hi > lo, hi - lo, 1.0)
    return np.clip(np.rint(t * top), 0, top).astype(np.uint32)


def _pack_111011(v, lo, hi) -> np.ndarray:
    return (_unorm(v[:, 0], lo[:, 0], hi[:, 0], 11) << 21 | _unorm(v[:, 1], lo[:, 1], hi[:, 1], 10) << 11
            | _unorm(v[:, 2], lo[:, 2], hi[:, 2], 11))


def _pack_rotation(q: np.ndarray) -> np.ndarray:
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    largest = np.argmax(np.abs(q), axis=1)
    q = q * np.where(np.take_along_axis(q, largest[:, None], 1) < 0, -1.0, 1.0)
    others = np.stack([np.where(largest <= j, q[:, j + 1] if j < 3 else 0, q[:, j]) for j in range(3)], 1)
    t = others / np.sqrt(2.0) + 0.5
    packed = largest.astype(np.uint32) << 30
    for j, shift in enumerate((20, 10, 0)):
        packed |= np.clip(np.rint(t[:, j] * 1023), 0, 1023).astype(np.uint32) << shift
    return packed


def write_compressed_ply(path, splats: SplatSet) -> list:
    s = splats.check().subset(_morton_order(splats.positions.astype(np.float64)))
    n, n_chunks = s.count, -(-s.count // CHUNK)
    owner = np.arange(n) // CHUNK
    pos = s.positions.astype(np.float64)
    log_scale = np.log(np.maximum(s.scales.astype(np.float64), 1e-30))
    color = s.sh_dc.astype(np.float64) * C0 + 0.5
    bounds = [_chunk_bounds(v, n_chunks) for v in (pos, log_scale, color)]
    chunk = np.concatenate([bounds[0][0], bounds[0][1], bounds[1][0], bounds[1][1],
                            bounds[2][0], bounds[2][1]], axis=1).astype("<f4")
    lo = lambda i: bounds[i][0][owner]  # noqa: E731
    hi = lambda i: bounds[i][1][owner]  # noqa: E731
    rgb = [_unorm(color[:, c], lo(2)[:, c], hi(2)[:, c], 8) for c in range(3)]
    alpha = np.clip(np.rint(s.opacities.astype(np.float64) * 255), 0, 255).astype(np.uint32)
    vertex = np.stack([_pack_111011(pos, lo(0), hi(0)), _pack_rotation(s.rotations.astype(np.float64)),
                       _pack_111011(log_scale, lo(1), hi(1)),
                       rgb[0] << 24 | rgb[1] << 16 | rgb[2] << 8 | alpha], axis=1).astype("<u4")
    k = s.sh_rest.shape[1]
    # reader: v -> (v + 0.5) / 256 * 8 - 4, so the nearest v is floor((x + 4) * 32)
    codes = np.floor((s.sh_rest.transpose(0, 2, 1).reshape(n, 3 * k) + 4.0) * 32)
    sh = np.clip(codes, 0, 255).astype(np.uint8)
    lines = ["ply", "format binary_little_endian 1.0", "comment written by Splatline"]
    lines += [f"comment {ANTIALIASED_COMMENT}"] if s.antialiased else []
    lines += [f"element chunk {n_chunks}"]
    lines += [f"property float {name}" for name in BOUNDS + COLOR_BOUNDS]
    lines += [f"element vertex {n}"] + [f"property uint {name}" for name in
                                         ("packed_position", "packed_rotation", "packed_scale", "packed_color")]
    if k:
        lines += [f"element sh {n}"] + [f"property uchar {name}" for name in rest_names(3 * k)]
    lines += ["end_header", ""]
    parts = ["\n".join(lines).encode("ascii"), chunk, vertex] + ([sh] if k else [])
    write_file(path, *parts)
    # its colours, positions and scales take each chunk's own range: only SH has fixed ends
    note = clamp_note("higher SH", "compressed PLY", codes, 255, "-4", f"{255 / 32 - 4:.3g}") if k else None
    return [note] if note else []
