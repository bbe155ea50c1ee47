"""The engine's Blender-GPU path: the viewport's drawing code into a GPUOffScreen.

It needs no wheel and no GL driver of its own: Blender's backend (OpenGL, Vulkan,
Metal) does the drawing, so a final render works wherever Blender's viewport does.
It runs on the thread where Blender's GPU context is current: render() of an engine
with bl_use_gpu_context = True (the moderngl path keeps its context on its own thread).

Same semantics as the other renderers except two things the viewport's drawing code
does not do: early termination, and the depth pass (moderngl's front-to-back batches
and Z attachment are not part of it), so RenderOutput.depth is +inf everywhere and the
engine says so once.
"""
from __future__ import annotations

import numpy as np

from ...core.scene import RenderOutput
from ..viewport import DrawSettings, ItemDisplay, ViewportRenderer
from ..viewport.offscreen import draw_camera

MAX_SH_DEGREE = 3  # what the shared shaders evaluate (shaders/splat_math.glsl)


def backend_name() -> str:
    """Blender's GPU backend, e.g. 'OPENGL', 'VULKAN', 'METAL'."""
    import gpu

    try:
        return str(gpu.platform.backend_type_get())
    except Exception:  # older builds, or no GPU yet: the label only
        return "unknown backend"


class GpuModuleRenderer:
    """render(items, camera, options) -> RenderOutput: a core.renderer.Renderer."""

    has_depth = has_holdout = has_panorama = has_defocus = has_early_termination = has_film = False

    def __init__(self):
        # Sorting inline: a final frame must draw its own order, not the last one.
        self._viewport = ViewportRenderer(worker=False)

    def render(self, items, camera, options) -> RenderOutput:
        if camera.equirect or camera.defocus is not None:
            raise ValueError("panoramic cameras and depth of field need the moderngl or "
                             "Reference renderer (the Blender GPU module path draws pinhole "
                             "cameras only)")
        if getattr(options, "holdout", None) is not None:
            raise ValueError("meshes hiding splats need the moderngl or Reference renderer "
                             "(the Blender GPU module path does not hold splats out); or set "
                             "Render > Splatline > Meshes to Ignored")
        settings = DrawSettings(sync_sort=True, linear_output=False,
                                antialiased=options.antialiased,
                                capped_extent=options.capped_extent)
        # No frustum dilation tuning, no viewport display overrides: the splats as they are.
        display = ItemDisplay(max_sh_degree=MAX_SH_DEGREE, key_bits=options.key_bits)
        rgba = draw_camera(items, camera, settings=settings, displays=[display] * len(items),
                           renderer=self._viewport, background=options.background)
        depth = np.full(rgba.shape[:2], np.inf, np.float32)
        # Free the GPU textures here, where Blender's GPU context is current. Blender 4.5
        # aborts (epoxy: no current EGL context) when they are freed at job end, from the
        # render_complete handler; so each frame uploads again: the fallback path trades
        # speed for working everywhere.
        self._viewport.close()
        return RenderOutput(rgba=np.ascontiguousarray(rgba), depth=depth)

    def close(self) -> None:
        self._viewport.close()  # holds no GPU objects between frames (see render)
