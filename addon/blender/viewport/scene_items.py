"""Which splat objects a 3D viewport shows, and their RenderItems, cached per geometry version.

The data of an object is read again (evaluate.item_for) only when its version
changes: a depsgraph update that is not transform-only, a frame change on a
time-dependent object, or an explicit invalidate. A transform-only change
reuses the cached item with the new world matrix, so the renderer uploads
nothing but the per-object table.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

import bpy

from .. import evaluate
from .renderer import ItemDisplay


def display_for(obj) -> ItemDisplay:
    settings = getattr(getattr(obj, "splatline", None), "display", None)
    if settings is None or not hasattr(settings, "splat_scale"):
        return ItemDisplay()
    return ItemDisplay(
        splat_scale=float(settings.splat_scale), max_sh_degree=int(settings.max_sh_degree),
        mode=settings.mode, sh_only=bool(settings.show_sh_only),
        cull=bool(settings.frustum_culling), dilation=float(settings.cull_dilation),
        key_bits=int(settings.sort_key_bits))


def time_dependent(obj) -> bool:
    """Objects whose splats may change with the frame without a geometry update."""
    settings = getattr(obj, "splatline", None)
    if settings is not None:
        if len(getattr(settings, "effects", ())) or getattr(settings.sequence, "enabled", False):
            return True
    for owner in (obj, obj.data):
        anim = getattr(owner, "animation_data", None)
        if anim is not None and (anim.action is not None or len(anim.drivers)):
            return True
    return False


class SceneItems:
    """Per-object item cache for the draw handler."""

    def __init__(self):
        self.versions: dict[str, int] = {}
        self.items: dict[str, tuple] = {}  # name -> (version, RenderItem)

    def invalidate(self, name: str | None = None) -> None:
        names = list(self.versions) if name is None else [name]
        for n in names:
            self.versions[n] = self.versions.get(n, 0) + 1

    def on_depsgraph(self, depsgraph) -> None:
        for update in depsgraph.updates:
            ident = update.id
            if isinstance(ident, bpy.types.Object):
                if update.is_updated_geometry or not update.is_updated_transform:
                    self.invalidate(ident.original.name)
            elif isinstance(ident, bpy.types.PointCloud):
                self._invalidate_users(ident.original)

    def _invalidate_users(self, data) -> None:
        for name in list(self.items):
            obj = bpy.data.objects.get(name)
            if obj is not None and obj.data == data:
                self.invalidate(name)

    def on_frame(self, scene) -> None:
        for name in list(self.items):
            obj = bpy.data.objects.get(name)
            if obj is None or time_dependent(obj):
                self.invalidate(name)

    def visible(self, context):
        """(evaluated object, original) for splat objects shown in this viewport."""
        depsgraph = context.evaluated_depsgraph_get()
        view_layer, space = context.view_layer, context.space_data
        for obj_eval in depsgraph.objects:
            if obj_eval.type != "POINTCLOUD" or not evaluate.is_splat_object(obj_eval):
                continue
            original = obj_eval.original
            if original.visible_get(view_layer=view_layer, viewport=space):
                yield obj_eval, original, depsgraph

    def collect(self, context) -> tuple[list, list]:
        items, displays = [], []
        seen = set()
        for obj_eval, original, depsgraph in self.visible(context):
            name = original.name
            seen.add(name)
            version = self.versions.setdefault(name, 0)
            cached = self.items.get(name)
            world = np.array(obj_eval.matrix_world, np.float64)
            if cached is None or cached[0] != version:
                # the evaluator's own key: with the arrays' identities it decides what
                # the renderer re-uploads (an effect that only fades uploads one texture)
                item = evaluate.item_for(obj_eval, depsgraph)
            else:
                item = replace(cached[1], world=world)
            self.items[name] = (version, item)
            items.append(item)
            displays.append(display_for(original))
        for name in set(self.items) - seen:  # deleted or hidden: let their data go
            del self.items[name]
        return items, displays
