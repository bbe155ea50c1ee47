"""Splats in Blender's 3D viewport through the gpu module.

- `draw_items(items, view_matrix, projection_matrix, viewport_size, ...)`: the drawing
  path shared by the draw handler, the render engine's view_draw and the tests.
- register() adds one ViewportDrawer (a POST_VIEW draw handler, depsgraph and frame
  handlers, the sort worker); unregister() removes all of it. Its panels live in
  ui/viewport.py and register themselves (ui/ reads viewport/, never the reverse).
No state is kept on bpy: the drawer lives in this module and is torn down in unregister.
"""
from __future__ import annotations

from .draw import close_shared, draw_items  # noqa: F401
from .viewport_renderer import DrawSettings, ItemDisplay, Stats, ViewportRenderer  # noqa: F401

_drawer = None


def drawer():
    """The live ViewportDrawer (None when unregistered): stats for the panels."""
    return _drawer


def register():
    global _drawer
    from . import handler

    _drawer = handler.ViewportDrawer()


def unregister():
    global _drawer

    if _drawer is not None:
        _drawer.close()
        _drawer = None
    close_shared()
