"""Evaluated splat objects -> RenderItems: the one place the viewport and the engine get data.

Per object, at the depsgraph's frame:
1. base splats (`base_splats`): a sequence frame (sequence_runtime) or the evaluated
   PointCloud, cached per (object, data, geometry version) since reading 1M splats costs ~1 s;
2. crop (look) as per-splat opacity;
3. the effect stack (core/effects) at time = frame / fps;
4. the look's colour matrix, opacity/size multipliers and SH cap on the RenderItem.
Nothing is carried from one frame to the next except pure caches, so frame t is a pure
function of the data and the property values at t.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

import bpy

from ..core import look as core_look
from ..core.effects import evaluate_stack
from ..core.scene import RenderItem
from . import effect_params
from .pointcloud import is_splat_data, splats_from_pointcloud

try:
    from . import sequence_runtime
except ImportError:  # the sequences layer is optional
    sequence_runtime = None


def _is_sequence(obj) -> bool:
    settings = getattr(getattr(obj, "splatline", None), "sequence", None)
    return bool(getattr(settings, "enabled", False))


def is_splat_object(obj) -> bool:
    return (obj is not None and obj.type == "POINTCLOUD"
            and (is_splat_data(obj.data) or _is_sequence(obj)))


def splat_objects(depsgraph):
    """Evaluated splat objects that the depsgraph considers visible (view layer, collections)."""
    for obj in depsgraph.objects:
        if is_splat_object(obj):
            yield obj


class BaseCache:
    """SplatSets read from evaluated PointClouds, keyed by what makes them change.

    `versions` counts geometry updates per PointCloud datablock (depsgraph_update_post);
    objects with modifiers are also keyed by frame, as their evaluated geometry may be
    animated. Cached arrays are read-only: kernels and renderers never write them.
    """

    def __init__(self):
        self.versions: dict[str, int] = {}
        self.entries: dict[str, tuple] = {}

    def key(self, obj_eval, depsgraph) -> tuple:
        original = obj_eval.original
        data_name = obj_eval.data.original.name_full
        frame = depsgraph.scene_eval.frame_float if len(original.modifiers) else None
        return (original.name_full, data_name, self.versions.get(data_name, 0),
                len(obj_eval.data.points), frame)

    def get(self, obj_eval, depsgraph):
        key = self.key(obj_eval, depsgraph)
        name = key[0]
        hit = self.entries.get(name)
        if hit is None or hit[0] != key:
            splats = splats_from_pointcloud(obj_eval.data)
            for array in (splats.positions, splats.scales, splats.rotations, splats.opacities,
                          splats.sh_dc, splats.sh_rest):
                array.flags.writeable = False
            hit = (key, splats)
            self.entries[name] = hit
        return hit[1], hit[0]

    def on_update(self, depsgraph) -> None:
        for update in depsgraph.updates:
            if isinstance(update.id, bpy.types.PointCloud) and update.is_updated_geometry:
                name = update.id.original.name_full
                self.versions[name] = self.versions.get(name, 0) + 1

    def clear(self) -> None:
        self.entries.clear()
        self.versions.clear()


_BASE = BaseCache()
_MORPH = effect_params.MorphCache()


def base_splats(obj_eval, depsgraph):
    """THE SEAM: (SplatSet, key) of an object before look and effects, at the depsgraph's
    frame. Equal keys mean identical splats. Sequence objects come from sequence_runtime."""
    if sequence_runtime is not None and _is_sequence(obj_eval):
        frame = sequence_runtime.sequence_frame(obj_eval, depsgraph)
        if frame is not None:
            return frame.splats, ("sequence", obj_eval.original.name_full) + tuple(frame.key)
    return _BASE.get(obj_eval, depsgraph)


def scene_time(depsgraph) -> tuple[float, float]:
    """(seconds, fps) of the depsgraph's frame (subframes included)."""
    scene = depsgraph.scene_eval
    fps = scene.render.fps / scene.render.fps_base
    return scene.frame_float / fps, fps


def _crop(look):
    box = sphere = None
    if look.use_crop_box:
        box = core_look.CropBox(tuple(look.crop_box_center), tuple(look.crop_box_size),
                                look.crop_box_softness, look.crop_box_invert)
    if look.use_crop_sphere:
        sphere = core_look.CropSphere(tuple(look.crop_sphere_center), look.crop_sphere_radius,
                                      look.crop_sphere_softness, look.crop_sphere_invert)
    return box, sphere


def _effect_stack(obj_eval, depsgraph, world, fps, source, source_key):
    """(core params list, signature of the position-changing ones)."""
    stack, signature = [], []
    for effect in obj_eval.splatline.effects:
        if not effect.enabled or effect.amount <= 0.0:
            continue
        frame = effect_params.gizmo_frame(effect, world, depsgraph)
        morph, extra = None, ()
        if effect.type == "MORPH":
            target = effect_params.evaluated(effect.target, depsgraph)
            if target is None or not is_splat_object(target):
                continue
            target_splats, target_key = base_splats(target, depsgraph)
            relative = np.linalg.solve(world, np.array(target.matrix_world, np.float64))
            morph = _MORPH.target(source, source_key, target_splats, target_key, relative)
            extra = (target_key, relative.tobytes())
        stack.append(effect_params.build(effect, frame, fps, morph))
        if effect.type in effect_params.POSITION_TYPES:
            signature.append(effect_params.signature(effect, frame, extra))
    return stack, tuple(signature)


def item_for(obj_eval, depsgraph=None) -> RenderItem:
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    world = np.array(obj_eval.matrix_world, np.float64)
    splats, key = base_splats(obj_eval, depsgraph)
    settings = getattr(obj_eval, "splatline", None)
    key = (obj_eval.original.name, key)  # key[0] is the object's name (callers match on it)
    if settings is None:
        return RenderItem(splats=replace(splats), world=world, key=key, positions_key=key)
    look = settings.look
    box, sphere = _crop(look)
    splats = core_look.apply_crop(splats, box, sphere)
    time, fps = scene_time(depsgraph)
    stack, signature = _effect_stack(obj_eval, depsgraph, world, fps, splats, key[1])
    result = evaluate_stack(splats, stack, time)
    positions_key = (key, time, signature) if result.positions_changed else key
    return RenderItem(
        splats=replace(result.splats), world=world, splat_scale=float(look.size),
        opacity_scale=float(look.opacity), sh_degree=int(look.max_sh_degree),
        color_matrix=core_look.color_matrix(tuple(look.tint), look.exposure, look.saturation,
                                            look.hue),
        key=key, positions_key=positions_key)


def collect_items(depsgraph) -> list[RenderItem]:
    return [item_for(obj, depsgraph) for obj in splat_objects(depsgraph)]


@bpy.app.handlers.persistent
def _on_depsgraph_update(_scene, depsgraph):
    _BASE.on_update(depsgraph)


@bpy.app.handlers.persistent
def _on_load(*_args):
    _BASE.clear()
    _MORPH.clear()


_HANDLERS = ((bpy.app.handlers.depsgraph_update_post, _on_depsgraph_update),
             (bpy.app.handlers.load_pre, _on_load))


def register():
    for handlers, fn in _HANDLERS:
        if fn not in handlers:
            handlers.append(fn)


def unregister():
    for handlers, fn in _HANDLERS:
        while fn in handlers:
            handlers.remove(fn)
    _on_load()
