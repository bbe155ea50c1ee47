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

# Cycles writes this for pixels that never hit anything; compositors expect a finite value.
BACKGROUND_DEPTH = 1e10


def blender_depth(depth: np.ndarray) -> np.ndarray:
    """View depth with Blender's background value where no splat reached alpha 0.5."""
    depth = np.asarray(depth, np.float32)
    return np.where(np.isfinite(depth), depth, np.float32(BACKGROUND_DEPTH)).astype(np.float32)


def bottom_up(image: np.ndarray) -> np.ndarray:
    """Top-down rows (renderers) -> a flat, contiguous bottom-up buffer (Blender's rect)."""
    return np.ascontiguousarray(image[::-1]).ravel()


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
