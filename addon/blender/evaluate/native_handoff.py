"""Splatline's evaluated splats, handed to Blender's own engines (Blender 5.3+ native splats).

Whichever engine renders (Workbench, EEVEE, Cycles) and in every viewport shading mode, the
splats Blender draws at a frame are `collect_items`' splats at that frame with the look
folded in (core/fold_look.baked_splats): effects, look, crop, morphs and sequences. They are
written into the object's companion (data/evaluated_geometry.py):
- at every frame change, including each frame of a render (frame_change_post receives the
  render's own depsgraph); the depsgraph is then updated, so the engine syncs what was
  written;
- after an edit (depsgraph_update_post), so the viewport follows the panels.
An object whose evaluation leaves its splats as stored gets no companion: Blender draws its
own data. Once it has one, the companion is kept and follows the splats, so keyframes that
switch effects on and off never add or remove modifiers during a render.

Render > Leave Out Far Outliers (on by default) hands each capture over without its few far
stray splats (native_outliers.py): EEVEE quantises centres against the whole cloud's
bounds. An object whose only change is that gets a companion too.

Splatline's own engine reads items itself: its renders skip the handoff.
"""
from __future__ import annotations

import contextlib
import threading

import numpy as np

import bpy

from ...core.fold_look import baked_splats
from ...core.scene import IDENTITY_COLOR, RenderItem
from ...core.splats import SplatSet
from ..data import evaluated_geometry as geometry
from ..data import native
from ..data.pointcloud import CASTER_MARK
from ..data.sources import is_splat_object, source_of
from .items import item_for, shown, splat_objects, stored_as_is
from .native_outliers import KeptSets, wanted
from ..registration import app_handlers

SPLATLINE_ENGINE = "SPLATLINE"


def changes_splats(item: RenderItem) -> bool:
    """True when the look, crop or effects change the item's base splats (whether those are
    the stored ones is the source table's to say)."""
    return (len(item.key) > 2 or item.splat_scale != 1.0
            or item.opacity_scale != 1.0 or item.effective_sh_degree < item.splats.sh_degree
            or not np.array_equal(item.color_matrix, IDENTITY_COLOR))


def _written_key(item: RenderItem | None, thinned: bool) -> tuple:
    if item is None:
        return ("hidden",)
    return (item.key, item.splat_scale, item.opacity_scale, item.effective_sh_degree,
            np.asarray(item.color_matrix, np.float64).tobytes(), thinned)


class Handoff:
    """What each companion holds (by its session uid): the item's key, so an unchanged item
    is not written again, and the arrays written, so a changed one writes only its changed
    attributes. One lock: a render thread and the UI may both sync."""

    def __init__(self):
        self.lock = threading.Lock()
        self.written: dict[int, tuple] = {}
        self.kept = KeptSets()
        self.syncing = False

    def sync(self, depsgraph) -> int:
        """Bring every natively drawn splat object's companion to the depsgraph's frame.
        Returns how many companions were written."""
        if not native.has_native_splats() or self.syncing:
            return 0
        with self.lock:
            self.syncing = True
            try:
                return sum(self._sync_object(obj, depsgraph) for obj in list(splat_objects(depsgraph)))
            finally:
                self.syncing = False

    def _sync_object(self, obj_eval, depsgraph) -> bool:
        original = obj_eval.original
        if not native.drawn_natively(original.data):
            return False
        drawn = shown(obj_eval)
        guard = drawn and wanted(depsgraph)
        other = geometry.claim(original)
        if (other is None and drawn and stored_as_is(obj_eval)
                and not (guard and self.kept.for_stored(obj_eval, depsgraph).dropped)):
            return False
        item = item_for(obj_eval, depsgraph) if drawn else None
        kept = self.kept.for_item(obj_eval, depsgraph, item).kept if guard else None
        if other is None:
            if (item is not None and source_of(obj_eval).stored and not changes_splats(item)
                    and kept is None):
                return False
            other = geometry.install(original)
        key = _written_key(item, kept is not None)
        held = self.written.get(other.session_uid)
        if held is not None and held[0] == key:
            return False
        splats = baked_splats(item) if item is not None else SplatSet.allocate(0, 0)
        if kept is not None:
            splats = splats.subset(kept)
        arrays = geometry.write(other, splats, held[1] if held is not None else None)
        self.written[other.session_uid] = (key, arrays)
        return True

    @contextlib.contextmanager
    def settling(self):
        self.syncing = True
        try:
            yield
        finally:
            self.syncing = False

    def clear(self) -> None:
        with self.lock:
            self.written.clear()
            self.kept.clear()


_HANDOFF = Handoff()


def sync(depsgraph) -> int:
    return _HANDOFF.sync(depsgraph)


def _skipped(scene, depsgraph) -> bool:
    """Splatline's own final render draws from items: Blender's engines see nothing, unless
    its mesh layer shows the splats' shadows (render/shadow_casters.py: the casters show the
    evaluated splats)."""
    return depsgraph.mode == "RENDER" and scene.render.engine == SPLATLINE_ENGINE and not _casts_shadows(scene)


def _casts_shadows(scene) -> bool:
    settings = getattr(scene, "splatline", None)
    meshes = None if settings is None else settings.render.mesh_scene
    return meshes is not None and any(CASTER_MARK in o.keys() for o in meshes.objects)


@bpy.app.handlers.persistent
def _on_frame_change(scene, depsgraph):
    if depsgraph is None or _skipped(scene, depsgraph):
        return
    if sync(depsgraph):
        with _HANDOFF.settling():  # its depsgraph_update_post has nothing new to sync
            depsgraph.update()  # the engine syncs right after this handler: let it see the write


def _touches_splats(depsgraph) -> bool:
    for update in depsgraph.updates:
        block = update.id
        if isinstance(block, bpy.types.Object) and is_splat_object(block.original):
            return True
        if isinstance(block, bpy.types.Scene):
            return True
    return False


@bpy.app.handlers.persistent
def _on_update(scene, depsgraph):
    # A companion's own write sends an update too: it touches no splat object, so it stops here.
    if native.has_native_splats() and not _skipped(scene, depsgraph) and _touches_splats(depsgraph):
        sync(depsgraph)


@bpy.app.handlers.persistent
def _on_load(*_args):
    _HANDOFF.clear()


# After an undo step the companions hold what that step saved: write them anew.
_HANDLERS = ((bpy.app.handlers.frame_change_post, _on_frame_change),
             (bpy.app.handlers.depsgraph_update_post, _on_update),
             (bpy.app.handlers.load_pre, _on_load),
             (bpy.app.handlers.undo_post, _on_load),
             (bpy.app.handlers.redo_post, _on_load))

register, unregister = app_handlers(_HANDLERS, on_unregister=_on_load)
