"""Splat data as float texels: the layout the viewport shaders read (no bpy, no gpu).

Every splat owns BASE_TEXELS consecutive RGBA32F texels in the "base" texture:
    0: position xyz (object space), opacity
    1: rotation w, x, y, z (normalised here; zero or NaN stay as they are and are culled)
    2: scale xyz, object slot (float: index into the per-object table)
    3: SH DC rgb, 0
and sh_texels(degree) texels in the "sh" texture: the higher SH coefficients
coefficient-major (r, g, b of coefficient 0, then of coefficient 1, ...),
padded to a whole texel. Texel t of a texture lives at (t % width, t // width).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.splats import SplatSet, sh_coeff_count

BASE_TEXELS = 4
MAX_WIDTH = 16384  # the smallest GL_MAX_TEXTURE_SIZE Blender supports
OBJECT_TEXELS = 9  # per-object table row: see gpu_draw.object_table


def sh_texels(degree: int) -> int:
    return -(-3 * sh_coeff_count(degree) // 4)


def texture_shape(texels: int) -> tuple[int, int]:
    """(width, height) of a 2D layout holding `texels`, at most MAX_WIDTH wide."""
    width = max(1, min(MAX_WIDTH, texels))
    height = max(1, -(-texels // width))
    if height > MAX_WIDTH:
        raise ValueError(f"{texels} texels do not fit a {MAX_WIDTH}^2 texture")
    return width, height


@dataclass
class Packed:
    """One object's texels, cached per geometry version (CPU side)."""

    base: np.ndarray  # (N, BASE_TEXELS, 4) float32, slot column filled at concatenation
    sh: np.ndarray    # (N, sh_texels(degree), 4) float32
    degree: int
    positions_soa: np.ndarray  # (3, N) float32, one row per axis, for sorting

    @property
    def count(self) -> int:
        return int(self.base.shape[0])

    @property
    def nbytes(self) -> int:
        return self.base.nbytes + self.sh.nbytes + self.positions_soa.nbytes


def pack(splats: SplatSet, max_degree: int = 3) -> Packed:
    n = splats.count
    degree = max(0, min(max_degree, splats.sh_degree))
    base = np.empty((n, BASE_TEXELS, 4), np.float32)
    base[:, 0, :3] = splats.positions
    base[:, 0, 3] = splats.opacities
    q = splats.rotations
    with np.errstate(all="ignore"):
        norm = np.sqrt(np.einsum("ij,ij->i", q, q))[:, None]
        base[:, 1] = np.where(norm > 0, q / norm, q)
    base[:, 2, :3] = splats.scales
    base[:, 2, 3] = 0.0
    base[:, 3, :3] = splats.sh_dc
    base[:, 3, 3] = 0.0
    k = sh_coeff_count(degree)
    sh = np.zeros((n, sh_texels(degree), 4), np.float32)
    if k:
        sh.reshape(n, -1)[:, :3 * k] = splats.sh_rest[:, :k].reshape(n, 3 * k)
    return Packed(base, sh, degree, np.ascontiguousarray(splats.positions.T, np.float32))


def concatenate(parts: list[Packed]) -> tuple[np.ndarray, np.ndarray, int]:
    """Every object's texels in one base and one sh array, laid out for a texture.

    Returns (base, sh, sh_stride): flat (H*W, 4) arrays padded to whole rows, with
    the object slot written into base texel 2's w, and the per-splat SH texel count
    (the largest degree present; lower-degree objects are zero-padded).
    """
    total = sum(p.count for p in parts)
    stride = max((p.sh.shape[1] for p in parts), default=0)
    bw, bh = texture_shape(max(1, total * BASE_TEXELS))
    base = np.empty((bw * bh, 4), np.float32)
    sw, shh = texture_shape(max(1, total * stride))
    sh = np.zeros((sw * shh, 4), np.float32)
    start = 0
    for slot, p in enumerate(parts):
        end = start + p.count
        view = base[start * BASE_TEXELS:end * BASE_TEXELS].reshape(p.count, BASE_TEXELS, 4)
        view[:] = p.base
        view[:, 2, 3] = slot
        if stride and p.sh.shape[1]:
            sh[start * stride:end * stride].reshape(p.count, stride, 4)[:, :p.sh.shape[1]] = p.sh
        start = end
    base[total * BASE_TEXELS:] = 0.0
    return base, sh, stride
