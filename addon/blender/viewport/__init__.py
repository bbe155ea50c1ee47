"""Splats in Blender's 3D viewport through the gpu module.

- `draw_items(items, view_matrix, projection_matrix, viewport_size, ...)`: the drawing
  path shared by the draw handler, the render engine's view_draw and the tests.
- register() adds one ViewportDrawer (a POST_VIEW draw handler, depsgraph and frame
  handlers, the sort worker) and the panels; unregister() removes all of it.
No state is kept on bpy: the drawer lives in this module and is torn down in unregister.
"""
from __future__ import annotations

from .renderer import DrawSettings, ItemDisplay, Stats, ViewportRenderer  # noqa: F401

_drawer = None
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


def drawer():
    """The live ViewportDrawer (None when unregistered): stats for the panels."""
    return _drawer


def register():
    global _drawer
    from . import handler, ui

    ui.register()
    _drawer = handler.ViewportDrawer()


def unregister():
    global _drawer, _shared
    from . import ui

    if _drawer is not None:
        _drawer.close()
        _drawer = None
    if _shared is not None:
        _shared.close()
        _shared = None
    ui.unregister()
