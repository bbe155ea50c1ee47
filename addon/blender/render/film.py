"""From a renderer's output to the shape of Blender's render result (pure numpy, no bpy).

Renderers give premultiplied display-referred sRGB, top-down rows (core/scene.py).
Blender's render result holds premultiplied scene-linear RGBA (the colour conversion is
core/colorspace.premultiplied_srgb_to_linear), bottom-up rows, a Depth pass with its own
background value, and only the region (border) Blender asks for: those conventions are here.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ...core.camera import Camera
from ...core.colorspace import srgb_decode_in_place

BLOCK_VALUES = 1 << 18  # floats per block of rows: 1 MiB, so each step's temporaries stay in cache

# Cycles writes this for pixels that never hit anything; compositors expect a finite value.
BACKGROUND_DEPTH = 1e10


def blender_depth(depth: np.ndarray) -> np.ndarray:
    """View depth with Blender's background value where no splat reached alpha 0.5."""
    depth = np.asarray(depth, np.float32)
    return np.where(np.isfinite(depth), depth, np.float32(BACKGROUND_DEPTH)).astype(np.float32, copy=False)


def bottom_up(image: np.ndarray) -> np.ndarray:
    """Top-down rows (renderers) -> a flat, contiguous bottom-up buffer (Blender's rect)."""
    return np.ascontiguousarray(image[::-1]).ravel()


def result_rect(rgba: np.ndarray, background=None, srgb: bool = True) -> np.ndarray:
    """A renderer's top-down premultiplied RGBA -> the Combined pass's rect: flat, bottom-up,
    scene-linear, over the world's colour where background is given (else as it is).

    srgb: rgba is display sRGB (a renderer's output) and is decoded; False: it is already
    scene-linear (motion blur's average). Bit for bit
    bottom_up(composite_over(premultiplied_srgb_to_linear(rgba), background)) wherever the
    colours are finite and >= 0 (what renderers give), done a few rows at a time into the
    one output array, every step on whole rows: at 1080p the whole-frame steps made five
    frame-sized temporaries, and their alpha and world broadcasts ran four floats at a time."""
    rgba = np.asarray(rgba, np.float32)
    h = rgba.shape[0]
    out = np.empty(rgba.shape, np.float32)
    step = max(1, BLOCK_VALUES // max(1, rgba[0].size))
    under = None
    if background is not None:
        under = np.zeros(4, np.float32)
        under[:3] = np.asarray(background, np.float32)[:3]
        # one row of it, to match the rows' floats; a black world adds +0 (colours >= 0:
        # nothing changes), so only alpha is set
        under = np.tile(under, rgba.shape[1]) if under.any() else None
    for r0 in range(0, h, step):
        r1 = min(h, r0 + step)
        block = out[r0:r1]
        source = rgba[h - r1:h - r0][::-1]  # output row r is the renderer's row h - 1 - r
        alpha = np.repeat(source[..., 3:4], 4, axis=-1)  # each pixel's alpha in all four
        if srgb:
            _to_linear(source, alpha, block)
        else:
            block[...] = source
        if background is not None:
            if under is not None:
                _over(block.reshape(r1 - r0, -1), alpha.reshape(r1 - r0, -1), under)
            block[..., 3] = 1.0
    return out.reshape(-1)


def _to_linear(source, alpha, out):
    """premultiplied_srgb_to_linear's steps into out. Dividing by +inf where alpha is not
    > 0 gives its zeros there (colours finite and >= 0), without a masked divide."""
    safe = np.where(alpha > 0, alpha, np.float32(np.inf))
    np.divide(source, safe, out=out)
    srgb_decode_in_place(out)
    out *= alpha
    out[..., 3] = source[..., 3]


def _over(rows, alpha, under_row):
    """composite_over's C + (1 - alpha) x world on rows of floats (alpha still the
    film's; the caller sets it to 1)."""
    alpha = np.subtract(np.float32(1.0), alpha, out=alpha)
    alpha *= under_row
    rows += alpha


@dataclass(frozen=True)
class Region:
    """The part of the full frame that Blender asks for, in Blender's pixel terms:
    x from the left, y from the BOTTOM (Blender's disprect), width, height."""

    x: int
    y: int
    width: int
    height: int


def render_region(frame_width: int, frame_height: int, use_border: bool,
                  border=(0.0, 1.0, 0.0, 1.0)) -> Region:
    """The region Blender renders: the whole frame, or the border.

    border is (min_x, max_x, min_y, max_y) as fractions. Blender truncates
    fraction * size in single precision (render_init_from_main); doing the same
    here makes the region match the render result Blender allocates.
    """
    if not use_border:
        return Region(0, 0, int(frame_width), int(frame_height))
    bx0, bx1, by0, by1 = (np.float32(v) for v in border)
    w, h = np.float32(frame_width), np.float32(frame_height)
    x0, x1 = int(bx0 * w), int(bx1 * w)
    y0, y1 = int(by0 * h), int(by1 * h)
    return Region(x0, y0, x1 - x0, y1 - y0)


def region_camera(camera: Camera, region: Region) -> Camera:
    """The full-frame camera restricted to region: same projection, moved principal point.

    The camera's image space is top-down, Blender's region is bottom-up.
    """
    top = camera.height - (region.y + region.height)
    return replace(camera, width=region.width, height=region.height,
                   cx=camera.cx - region.x, cy=camera.cy - top)
