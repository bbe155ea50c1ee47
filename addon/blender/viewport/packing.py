"""Splat data as float texels: the layout the viewport shaders read (no bpy, no gpu).

Three RGBA32F data textures, so that an effect changing only some fields re-uploads
only their texture (each is cached by the identity of the arrays it is built from):
    pos    1 texel per splat:  position xyz (object space), opacity
    shape  3 texels per splat: rotation w, x, y, z (normalised here); scale xyz,
           object slot (index into the per-object table); SH DC rgb, 0
    sh     `stride` texels per splat: the higher SH coefficients, coefficient-major
           (r, g, b of coefficient 0, then 1, ...), zero-padded to the stride
Every texture is WIDTH texels wide; texel t lives at (t % WIDTH, t // WIDTH).
"""
from __future__ import annotations

import numpy as np

from ...core.splats import SplatSet, sh_coeff_count

WIDTH = 4096          # texels per row of every data texture
MAX_HEIGHT = 16384    # the smallest GL_MAX_TEXTURE_SIZE Blender supports
SHAPE_TEXELS = 3
OBJECT_TEXELS = 9     # per-object table row: see gpu_draw.object_rows


def sh_texels(degree: int) -> int:
    return -(-3 * sh_coeff_count(degree) // 4)


def padded(texels: int) -> int:
    """Texel count rounded up to whole rows (at least one row)."""
    rows = max(1, -(-texels // WIDTH))
    if rows > MAX_HEIGHT:
        raise ValueError(f"{texels} texels do not fit a {WIDTH}x{MAX_HEIGHT} texture")
    return rows * WIDTH


def _alloc(n: int, per_splat: int) -> tuple[np.ndarray, np.ndarray]:
    """A padded flat (texels, 4) array and its (n, per_splat, 4) view; padding zeroed."""
    flat = np.empty((padded(n * per_splat), 4), np.float32)
    flat[n * per_splat:] = 0.0
    return flat, flat[:n * per_splat].reshape(n, per_splat, 4)


def pack_pos(splats: SplatSet) -> np.ndarray:
    flat, view = _alloc(splats.count, 1)
    view[:, 0, :3] = splats.positions
    view[:, 0, 3] = splats.opacities
    return flat


def pack_shape(splats: SplatSet, slot: int = 0) -> np.ndarray:
    flat, view = _alloc(splats.count, SHAPE_TEXELS)
    q = splats.rotations
    with np.errstate(all="ignore"):
        norm = np.sqrt(np.einsum("ij,ij->i", q, q))[:, None]
        view[:, 0] = np.where(norm > 0, q / norm, q)  # zero/NaN stay, the shader culls them
    view[:, 1, :3] = splats.scales
    view[:, 1, 3] = slot
    view[:, 2, :3] = splats.sh_dc
    view[:, 2, 3] = 0.0
    return flat


def pack_sh(splats: SplatSet, degree: int, stride: int) -> np.ndarray:
    """Coefficients up to `degree`, `stride` texels per splat (stride >= sh_texels(degree))."""
    n = splats.count
    flat, view = _alloc(n, stride)
    k = sh_coeff_count(max(0, min(degree, splats.sh_degree)))
    flat_view = view.reshape(n, stride * 4)
    flat_view[:, 3 * k:] = 0.0
    if k:
        flat_view[:, :3 * k] = splats.sh_rest[:, :k].reshape(n, 3 * k)
    return flat


def concatenate(parts: list[np.ndarray], counts: list[int], per_splat: int) -> np.ndarray:
    """Several objects' padded arrays as one padded array (the first texels of each)."""
    total = sum(counts)
    flat = np.empty((padded(total * per_splat), 4), np.float32)
    start = 0
    for part, n in zip(parts, counts):
        flat[start:start + n * per_splat] = part[:n * per_splat]
        start += n * per_splat
    flat[start:] = 0.0
    return flat


def set_slots(shape: np.ndarray, counts: list[int]) -> None:
    """Write each object's slot into texel 1's w of its splats (concatenated shape)."""
    view = shape[:sum(counts) * SHAPE_TEXELS].reshape(-1, SHAPE_TEXELS, 4)
    start = 0
    for slot, n in enumerate(counts):
        view[start:start + n, 1, 3] = slot
        start += n
