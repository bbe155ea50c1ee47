"""ViewportDrawer: the POST_VIEW draw handler and everything it owns.

Owned here, and removed in close(): the SpaceView3D draw handler, the
depsgraph_update_post and frame_change_post handlers, the sort worker thread and
the redraw timer (only registered while a background sort is in flight).
bpy.app.handlers need module-level functions marked persistent (so a file load
does not drop them); they forward to the one live drawer.
"""
from __future__ import annotations

import threading
import traceback
from dataclasses import replace

import bpy
import gpu

from ..evaluate.lighting import lighting_for
from .draw import draw_items
from .viewport_renderer import DrawSettings, ViewportRenderer
from .scene_items import SceneItems

_live = None  # the registered drawer, for the persistent bpy.app handlers
POLL_SECONDS = 0.02
ENGINE_IDNAME = "SPLATLINE"  # engine.py's RenderEngine draws in its own view_draw


@bpy.app.handlers.persistent
def _on_depsgraph(scene, depsgraph=None):
    if _live is not None and depsgraph is not None:
        _live.items.on_depsgraph(depsgraph)


@bpy.app.handlers.persistent
def _on_frame(scene, depsgraph=None):
    if _live is not None:
        _live.items.on_frame(scene)


def _redraw_timer():
    """Tag the 3D views for redraw once the background sort is done."""
    drawer = _live
    if drawer is None:
        return None
    if drawer.sorted_event.is_set():
        drawer.sorted_event.clear()
        tag_view3d_redraw()
    return POLL_SECONDS if drawer.renderer.sorting else None


def tag_view3d_redraw() -> None:
    wm = getattr(bpy.context, "window_manager", None)
    for window in getattr(wm, "windows", ()):
        for area in window.screen.areas:
            if area.type == "VIEW_3D":
                area.tag_redraw()


class ViewportDrawer:
    def __init__(self):
        global _live
        self.sorted_event = threading.Event()
        self.renderer = ViewportRenderer(worker=True, on_sorted=self.sorted_event.set)
        self.items = SceneItems()
        self.settings = DrawSettings(sync_sort=False)
        self.last_error = None
        self._handle = bpy.types.SpaceView3D.draw_handler_add(self.draw, (), "WINDOW", "POST_VIEW")
        bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph)
        bpy.app.handlers.frame_change_post.append(_on_frame)
        _live = self

    def close(self) -> None:
        global _live
        if self._handle is not None:
            bpy.types.SpaceView3D.draw_handler_remove(self._handle, "WINDOW")
            self._handle = None
        for handlers, fn in ((bpy.app.handlers.depsgraph_update_post, _on_depsgraph),
                             (bpy.app.handlers.frame_change_post, _on_frame)):
            while fn in handlers:
                handlers.remove(fn)
        if bpy.app.timers.is_registered(_redraw_timer):
            bpy.app.timers.unregister(_redraw_timer)
        self.renderer.close()
        if _live is self:
            _live = None

    @property
    def stats(self):
        return self.renderer.stats

    @staticmethod
    def _engine_draws(context) -> bool:
        """Rendered shading with the Splatline engine: its view_draw shows the splats."""
        shading = getattr(context.space_data, "shading", None)
        return (shading is not None and shading.type == "RENDERED"
                and context.scene.render.engine == ENGINE_IDNAME)

    def draw(self) -> None:
        context = bpy.context
        region, rv3d = context.region, context.region_data
        if rv3d is None or region is None or self._engine_draws(context):
            return
        try:
            items, displays = self.items.collect(context)
            if not items:
                self.renderer.stats.total = self.renderer.stats.drawn = 0
                return
            settings = replace(self.settings, lighting=lighting_for(items, context.evaluated_depsgraph_get()))
            draw_items(items, rv3d.view_matrix, rv3d.window_matrix, (region.width, region.height),
                       settings, displays, self.renderer, occlude=True)
            if self.renderer.sorting and not bpy.app.timers.is_registered(_redraw_timer):
                bpy.app.timers.register(_redraw_timer, first_interval=POLL_SECONDS)
        except Exception as exc:  # a draw callback must never raise into Blender's draw loop
            if repr(exc) != repr(self.last_error):
                traceback.print_exc()  # once per distinct error, not on every redraw
            self.last_error = exc
            gpu.state.depth_test_set("NONE")
            gpu.state.blend_set("NONE")
