"""Evaluated splat objects -> RenderItems: the one place the viewport and the engine get data.

Per object, at the depsgraph's frame:
1. base splats (`base_splats`): from the object's row of the source table (data/sources.py):
   its stored PointCloud, a sequence frame, ...; with the rest centres noise samples;
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

from ...core import look as core_look
from ...core.effects import StackResult, evaluate_stack
from ...core.effects.common import stop_helper
from ...core.effects.deferral import drawn_splats, split_stack
from ...core.effects.recycle import BUFFERS
from ...core.scene import IDENTITY_COLOR, RenderItem
from ...core.splats import ARRAYS
from . import effect_params
from .instancers import may_instance_splats
from .lighting import amount as lighting_amount, clear as clear_lighting, lit_item, scene_lighting
from ..registration import app_handlers
from ..data.source_kind import SourceFrame
from ..data.sources import is_splat_object, source_of
from ..data.stored_splats import CACHE


def splat_objects(depsgraph):
    """Evaluated splat objects that the depsgraph considers visible (view layer, collections),
    without their instances (splat_instances has those)."""
    for obj in depsgraph.objects:
        if is_splat_object(obj):
            yield obj


NO_INDEX = 2 ** 31 - 1  # a persistent id's unused levels


def instance_path(instance) -> tuple:
    """() for an object drawn as itself; else (its instancer's name_full, the instance's
    persistent id without its unused levels): unique among a depsgraph's instances, and the
    same from frame to frame while the instancer is."""
    if not instance.is_instance:
        return ()
    pid = list(instance.persistent_id)
    while pid and pid[-1] == NO_INDEX:
        pid.pop()
    return (instance.parent.original.name_full, *pid)


def splat_instances(depsgraph):
    """(evaluated object, (4, 4) world matrix, instance path) of every splat object the
    depsgraph draws: objects as themselves, and their collection, Geometry Nodes and
    vertex/face instances. The object is valid only until the next item is asked for
    (Blender's instance iterator): evaluate it before. Where no object may instance splats
    (instancers.py), the objects alone: walking the instances costs microseconds each."""
    if not may_instance_splats(depsgraph):
        for obj in splat_objects(depsgraph):
            yield obj, np.array(obj.matrix_world, np.float64), ()
        return
    for instance in depsgraph.object_instances:
        obj = instance.object
        if instance.show_self and is_splat_object(obj):
            yield obj, np.array(instance.matrix_world, np.float64), instance_path(instance)


def source_ident(obj_eval) -> tuple:
    """What instances of one source have in common: its object and data. A geometry that
    Geometry Nodes realised (Object Info with As Instance off) comes as a temporary object
    whose original is the modifier's holder: its data tells such geometries apart."""
    data = obj_eval.data
    return obj_eval.original.name_full, data.name_full, len(data.points)


SPLAT_FIELDS = frozenset(ARRAYS)


def source_frame(obj_eval, depsgraph) -> SourceFrame:
    """An object's splats before look and effects, at the depsgraph's frame, from its row of
    the source table. Equal keys mean identical splats."""
    return source_of(obj_eval).frame(obj_eval, depsgraph)


def base_splats(obj_eval, depsgraph):
    """(SplatSet, key) of an object before look and effects (source_frame's)."""
    frame = source_frame(obj_eval, depsgraph)
    return frame.splats, frame.key


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


def item_for(obj_eval, depsgraph=None, defer=None) -> RenderItem:
    """The RenderItem of one evaluated splat object.

    key: (name, base key) while the splats are the base data itself; with crop or effects,
    (name, base key, crop, effect signatures incl. time for time-driven effects), so equal
    keys mean equal splats and a renderer's per-key upload cache never shows a stale frame.
    defer(params) -> bool: the caller applies such effects (colour effects, a last morph,
    a displace) itself where the stack allows it (core.effects.deferral); they are then on
    item.deferred, not in its splats (but for the centres a deferred morph or displace
    moves: the caller sorts by them). A source whose splats move by themselves defers
    nothing: its splats are uploaded anew each frame anyway, and a deferred field would
    be measured at other centres than the stack's.
    """
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    world = np.array(obj_eval.matrix_world, np.float64)
    source = source_of(obj_eval)
    frame = source.frame(obj_eval, depsgraph)
    base, base_key = frame.splats, frame.key
    # key[0] is the object's name_full (callers match on it): a linked object may share
    # its .name with a local one
    name = obj_eval.original.name_full
    settings = getattr(obj_eval, "splatline", None)
    if settings is None:
        key = (name, base_key)
        return RenderItem(splats=replace(base), world=world, key=key, positions_key=key,
                          base_key=key, base_fields=SPLAT_FIELDS)
    look = settings.look
    box, sphere = _crop(look)
    splats = core_look.apply_crop(base, box, sphere)
    time, fps = scene_time(depsgraph)
    effects = effect_params.stack(obj_eval, depsgraph, world, time, fps, splats, base_key,
                                  base_splats)
    if source.moves_splats:
        defer = None
    on_cpu, deferred = split_stack(effects.params, defer) if defer else (effects.params, ())
    result = evaluate_stack(splats, on_cpu, time, rest=frame.rest)
    if deferred:
        drawn, deferred = drawn_splats(result.splats, deferred, time)
        result = StackResult(drawn, drawn.positions is not splats.positions)
    key = (name, base_key)
    if result.splats is not base or deferred:
        key = (name, base_key, (box, sphere), effects.signature)
    positions_key = (name, base_key, effects.moving) if result.positions_changed else (name, base_key)
    return RenderItem(
        splats=replace(result.splats), world=world, splat_scale=float(look.size),
        opacity_scale=float(look.opacity) if look.visible else 0.0, sh_degree=int(look.max_sh_degree),
        color_matrix=_color_matrix(look),
        key=key, positions_key=positions_key, base_key=(name, base_key),
        base_fields=frozenset(f for f in SPLAT_FIELDS if _kept(getattr(result.splats, f), getattr(base, f))),
        deferred=deferred, rest_positions=splats.positions if deferred else None)


def _kept(array: np.ndarray, base_array: np.ndarray) -> bool:
    """Whether a field's array holds the same values for as long as it lives: the base's
    own, or a read-only one (a deferred morph's memoized ends, core.effects.morph.aligned),
    which a renderer may keep what it uploaded of while the array is the same."""
    return array is base_array or not array.flags.writeable


def _color_matrix(look):
    return core_look.color_matrix(tuple(look.tint), look.exposure, look.saturation, look.hue)


def stored_as_is(obj_eval) -> bool:
    """True when item_for would certainly give the object's stored splats with a default
    look, read from its settings alone: Blender 5.3's handoff then needs no companion and
    never reads the splats back (a million of them cost 0.6 s of CPU and 420 MB on the
    first save after an import). False where unsure: item_for decides then."""
    if not source_of(obj_eval).stored:
        return False
    settings = getattr(obj_eval, "splatline", None)
    if settings is None:
        return True
    look = settings.look
    if (any(effect.enabled for effect in settings.effects)
            or _crop(look) != (None, None)):
        return False
    # max_sh_degree tops out at 3, the most Splatline reads: no band is then cut
    return (look.visible and look.size == 1.0 and look.opacity == 1.0 and look.max_sh_degree >= 3
            and np.array_equal(_color_matrix(look), IDENTITY_COLOR))


def shown(obj_eval) -> bool:
    """False for objects whose Look > Show is off (evaluated, e.g. as morph targets, not drawn)."""
    look = getattr(getattr(obj_eval, "splatline", None), "look", None)
    return bool(getattr(look, "visible", True))


def collect_items(depsgraph, defer=None, defer_lighting: bool = False) -> list[RenderItem]:
    """The items of every splat object and instance drawn. A source is evaluated once: its
    instances are its item (the same splats, key, look and effects) at their own world
    matrices, so a renderer uploads their splats once and sorts them all as one set.
    defer_lighting: leave Look > Lighting to the renderer (RenderItem.lighting; the viewport)."""
    items, evaluated, lighting = [], {}, None
    for obj, world, path in splat_instances(depsgraph):
        ident = source_ident(obj)
        level = lighting_amount(obj)
        lit_here = level > 0 and not defer_lighting
        if ident not in evaluated:
            # lit colours come after every effect: none is left to the renderer then
            evaluated[ident] = item_for(obj, depsgraph, None if lit_here else defer) if shown(obj) else None
        item = evaluated[ident]
        if item is not None:
            item = placed(item, world, path)
            if lit_here:
                lighting = lighting or scene_lighting(depsgraph)
                item = lit_item(item, lighting, level, depsgraph)
            elif level > 0:
                item = replace(item, lighting=level)
            items.append(item)
    return items


def placed(item: RenderItem, world: np.ndarray, path: tuple) -> RenderItem:
    """The item drawn at `world` as instance `path` (sharing its arrays)."""
    if path == item.instance and np.array_equal(world, item.world):
        return item
    return replace(item, world=world, instance=path)


def any_antialiased(depsgraph) -> bool:
    """Whether a splat object the frame draws is flagged as an anti-aliased capture
    (Object.splatline.antialiased, set on import from the file)."""
    return any(obj.splatline.antialiased for obj in splat_objects(depsgraph) if shown(obj))


@bpy.app.handlers.persistent
def _on_depsgraph_update(_scene, depsgraph):
    CACHE.on_update(depsgraph)


@bpy.app.handlers.persistent
def _on_load(*_args):
    CACHE.clear()
    clear_lighting()
    effect_params.TARGETS.clear()
    BUFFERS.clear()  # kept output buffers (a morph's sh_rest) of the old file's splats


_HANDLERS = ((bpy.app.handlers.depsgraph_update_post, _on_depsgraph_update),
             (bpy.app.handlers.load_pre, _on_load))


def _on_unregister():
    _on_load()
    stop_helper()  # the effects' block thread (core/effects/common.for_blocks)


register, unregister = app_handlers(_HANDLERS, on_unregister=_on_unregister)
