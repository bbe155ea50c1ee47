"""draw_items: the one drawing path into a bound framebuffer, shared by the draw handler,
the render engine's view_draw, the offscreen path and the tests. Its own module so that the
handler and the offscreen path import it without importing the package that registers them."""
from __future__ import annotations

from .viewport_renderer import DrawSettings, ViewportRenderer

_shared = None  # renderer for draw_items callers that bring none (the engine's view_draw)


def draw_items(items, view_matrix, projection_matrix, viewport_size, settings=None,
               displays=None, renderer: ViewportRenderer | None = None,
               occlude: bool = True) -> ViewportRenderer:
    """Draw RenderItems into the bound framebuffer, sorted back to front.

    view_matrix: world -> camera (Blender, looks down -z); projection_matrix: OpenGL
    clip matrix; viewport_size: (width, height) pixels of the bound framebuffer.
    occlude: test against the bound depth buffer (the scene's meshes hide splats behind
    them); splats never write depth, so they do not hide each other or the overlays.
    """
    import gpu

    global _shared
    if renderer is None:
        if _shared is None:
            _shared = ViewportRenderer()
        renderer = _shared
    if occlude:
        gpu.state.depth_test_set("LESS_EQUAL")
    try:
        renderer.draw(items, view_matrix, projection_matrix, viewport_size,
                      settings or DrawSettings(), displays)
    finally:
        if occlude:
            gpu.state.depth_test_set("NONE")
    return renderer


def close_shared() -> None:
    """Free the shared renderer's GPU buffers (the package's unregister)."""
    global _shared
    if _shared is not None:
        _shared.close()
        _shared = None
