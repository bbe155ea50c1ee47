"""The viewport's drawing path into a GPUOffScreen, read back as a top-down image.

Used by the render engine's Blender-GPU path (gpu_render.py) and by the tests: the
very code the 3D viewport draws with, so the two cannot drift apart. Needs a current
Blender GPU context: an engine with bl_use_gpu_context, the UI, or (tests) testing/headless.ensure_gpu.
"""
from __future__ import annotations

import numpy as np

from .draw import draw_items
from ...core.clip_space import projection_matrix
from .viewport_renderer import DrawSettings, ViewportRenderer


def draw_camera(items, camera, *, settings: DrawSettings | None = None, displays=None,
                renderer: ViewportRenderer | None = None,
                background=(0.0, 0.0, 0.0, 0.0)) -> np.ndarray:
    """Draw items as `camera` (core Camera) sees them; (H, W, 4) float32, top-down rows.

    background: premultiplied RGBA behind the splats. Cleared into the target, it ends up
    as C + T*bg under premultiplied blending: the reference's definition.
    The offscreen is made and freed here, per call: a framebuffer belongs to the GPU
    context that made it, and a render job ends (render_complete) on another thread.
    """
    import gpu

    w, h = camera.width, camera.height
    # RGBA32F: the splats blend in float, as the moderngl path and the reference do.
    offscreen = gpu.types.GPUOffScreen(w, h, format="RGBA32F")
    try:
        with offscreen.bind():
            fb = gpu.state.active_framebuffer_get()
            fb.clear(color=tuple(float(c) for c in background), depth=1.0)
            draw_items(items, camera.world_to_camera, projection_matrix(camera), (w, h),
                       settings or DrawSettings(), displays, renderer, occlude=False)
            rgba = np.empty((h, w, 4), np.float32)
            # Read straight into the numpy array (a Buffer wraps its memory): no Python
            # sequence copy, which costs seconds at 1080p.
            fb.read_color(0, 0, w, h, 4, 0, "FLOAT", data=gpu.types.Buffer("FLOAT", rgba.size, rgba))
    finally:
        offscreen.free()
    return rgba[::-1]  # GL rows are bottom-up; renderers give top-down
