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

from ..evaluate import items as evaluate
from ..evaluate.instancers import may_instance_splats
from ..evaluate.lighting import amount as lighting_amount
from ..data import native
from ..data.sources import is_splat_object, source_of
from .effect_rows import on_gpu
from .viewport_renderer import ItemDisplay


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
    source = source_of(obj)
    if source is not None and source.depends_on_time:
        return True
    if len(getattr(getattr(obj, "splatline", None), "effects", ())):
        return True
    for owner in (obj, obj.data):
        anim = getattr(owner, "animation_data", None)
        if anim is not None and (anim.action is not None or len(anim.drivers)):
            return True
    return False


def _effects(obj):
    return getattr(getattr(obj, "splatline", None), "effects", ())


def effect_inputs(obj) -> set[str]:
    """Names of the other objects whose transform or data the object's effects read:
    every effect's gizmo and morph target."""
    return {ref.name_full for effect in _effects(obj) for ref in (effect.gizmo, effect.target)
            if ref is not None}


def reads_own_transform(obj) -> bool:
    """Effect fields sit at the object's origin in world-aligned axes, or in a gizmo's
    frame: with effects, moving the object moves its splats through them."""
    return len(_effects(obj)) > 0


def settings_signature(obj, skip=("display",)) -> tuple:
    """The values of Object.splatline except the viewport-only display options.

    Cheap (a few dozen properties) and enough to tell a look/effect/sequence edit from a
    selection change, which also sends a depsgraph update but must not re-read 1M splats.
    """
    settings = getattr(obj, "splatline", None)
    modifiers = tuple((m.name, m.type, m.show_viewport) for m in obj.modifiers)
    own = _group_values(settings, skip) if settings is not None else ()
    return (getattr(obj.data, "name", None), modifiers, own)


def _group_values(group, skip=()) -> tuple:
    out = []
    for prop in group.bl_rna.properties:
        key = prop.identifier
        if key == "rna_type" or key in skip:
            continue
        value = getattr(group, key)
        if prop.type == "COLLECTION":
            value = tuple(_group_values(v) for v in value)
        elif prop.type == "POINTER":
            value = _group_values(value) if isinstance(value, bpy.types.PropertyGroup) else (
                getattr(value, "name", None))
        elif getattr(prop, "is_array", False):
            value = tuple(value)
        out.append((key, value))
    return tuple(out)


def by_full_name() -> dict:
    """{name_full: object}: items are keyed by name_full, since a linked object may share
    its .name with a local one (bpy.data.objects.get(name) finds only one of them)."""
    return {obj.name_full: obj for obj in bpy.data.objects}


def lit_shading(space) -> bool:
    """Look > Lighting shows in Material Preview and Rendered shading, as Blender's own
    lights do (and where no 3D view is known: scripts, tests)."""
    shading = getattr(space, "shading", None)
    return shading is None or shading.type in {"MATERIAL", "RENDERED"}


def _drawn(depsgraph):
    """(evaluated object, world, instance path, the original whose visibility decides) of
    what the depsgraph draws: its objects, and their instances where some object may
    instance splats (evaluate/instancers.py: walking instances costs microseconds each)."""
    if not may_instance_splats(depsgraph):
        for obj in depsgraph.objects:
            if obj.type == "POINTCLOUD":
                yield obj, np.array(obj.matrix_world, np.float64), (), obj.original
        return
    for instance in depsgraph.object_instances:
        if instance.show_self:
            obj = instance.object
            owner = instance.parent.original if instance.is_instance else obj.original
            yield obj, np.array(instance.matrix_world, np.float64), evaluate.instance_path(instance), owner


class SceneItems:
    """Per-object item cache for the draw handler."""

    def __init__(self):  # keyed by the objects' name_full
        self.versions: dict[str, int] = {}
        self.items: dict[str, tuple] = {}  # name_full -> (version, RenderItem, source_ident)
        self.signatures: dict[str, tuple] = {}  # name_full -> settings_signature when last read

    def invalidate(self, name: str | None = None) -> None:
        names = list(self.versions) if name is None else [name]
        for n in names:
            self.versions[n] = self.versions.get(n, 0) + 1

    def on_depsgraph(self, depsgraph) -> None:
        """Bump versions for data changes; skip transform-only and display-only edits.

        Flags Blender sends (bpy 5.0): a transform edit sets only is_updated_transform;
        a modifier or node change sets geometry without transform; any RNA property
        edit on the object (display options included) sets all three, and there the
        settings signature decides whether the data can have changed.
        """
        unchanged, moved = set(), set()
        for update in depsgraph.updates:
            ident = update.id
            if not isinstance(ident, bpy.types.Object):
                continue
            name = ident.original.name_full
            if update.is_updated_transform or update.is_updated_geometry:
                moved.add(name)
            if not update.is_updated_geometry:
                continue
            if update.is_updated_transform and update.is_updated_shading and name in self.items:
                signature = settings_signature(ident.original)
                if self.signatures.get(name) == signature:
                    unchanged.add(name)
                    continue
                self.signatures[name] = signature
            self.invalidate(name)
        for update in depsgraph.updates:
            if isinstance(update.id, bpy.types.PointCloud):
                self._invalidate_users(update.id.original, skip=unchanged)
        if moved:
            self._invalidate_readers(moved)

    def _invalidate_readers(self, moved: set) -> None:
        """Objects whose effects read another object that moved or changed (gizmo, morph
        target). Their own moves are caught in collect, by the world matrix: the depsgraph
        flags of an RNA edit cannot tell a move from a display-option change."""
        objects = by_full_name()
        for name in list(self.items):
            obj = objects.get(name)
            if obj is not None and not moved.isdisjoint(effect_inputs(obj)):
                self.invalidate(name)

    def _invalidate_users(self, data, skip=()) -> None:
        objects = by_full_name()
        for name in list(self.items):
            obj = objects.get(name)
            if name not in skip and obj is not None and obj.data == data:
                self.invalidate(name)

    def on_frame(self, scene) -> None:
        objects = by_full_name()
        for name in list(self.items):
            obj = objects.get(name)
            if obj is None or time_dependent(obj):
                self.invalidate(name)

    def visible(self, context):
        """(evaluated object, original, depsgraph, world matrix, instance path) for splat
        objects and their instances shown in this viewport (evaluate.items.splat_instances:
        the object is valid only until the next one is asked for). Objects whose Look > Show
        is off are left out: nothing is packed, uploaded or sorted for them (a morph target
        is read through its source's effect). An instance is shown where its instancer is."""
        depsgraph = context.evaluated_depsgraph_get()
        view_layer, space = context.view_layer, context.space_data
        for obj_eval, world, path, owner in _drawn(depsgraph):
            if obj_eval.type != "POINTCLOUD" or not is_splat_object(obj_eval) or not evaluate.shown(obj_eval):
                continue
            if native.drawn_natively(obj_eval.original.data):  # Blender draws it: never twice
                continue
            if owner.visible_get(view_layer=view_layer, viewport=space):
                yield obj_eval, obj_eval.original, depsgraph, world, path

    def collect(self, context) -> tuple[list, list]:
        """The items and display options of what this viewport shows: each source read once
        a draw, its instances drawn from its item (they share its arrays)."""
        items, displays = [], []
        seen, fresh = set(), {}
        shaded = lit_shading(context.space_data)
        for obj_eval, original, depsgraph, world, path in self.visible(context):
            ident = evaluate.source_ident(obj_eval)
            level = lighting_amount(obj_eval) if shaded else 0.0
            if ident not in fresh:
                seen.add(original.name_full)
                fresh[ident] = self._item(obj_eval, original, depsgraph)
            item = evaluate.placed(fresh[ident], world, path)
            if level > 0:  # lit by the preprocess pass: a light moved uploads the table alone
                item = replace(item, lighting=level)
            items.append(item)
            displays.append(display_for(original))
        for name in set(self.items) - seen:  # deleted or hidden: let their data go
            del self.items[name]
        return items, displays

    def _item(self, obj_eval, original, depsgraph):
        """The object's item at its own place, read again only when its version changed."""
        name = original.name_full
        version = self.versions.setdefault(name, 0)
        cached = self.items.get(name)
        world = np.array(obj_eval.matrix_world, np.float64)
        moved = cached is not None and reads_own_transform(original) and \
            not np.array_equal(cached[1].world, world)
        ident = evaluate.source_ident(obj_eval)
        if cached is None or cached[0] != version or moved or cached[2] != ident:
            self.signatures[name] = settings_signature(original)
            # the evaluator's own key: with the arrays' identities it decides what
            # the renderer re-uploads (an effect that only fades uploads one texture)
            # colour effects the preprocess pass can apply are left to it
            item = evaluate.item_for(obj_eval, depsgraph, defer=on_gpu)
        else:
            item = replace(cached[1], world=world)
        self.items[name] = (version, item, ident)
        return item
