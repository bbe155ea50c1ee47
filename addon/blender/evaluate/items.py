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

import threading
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
from ..registration import app_handlers
from ..data.evaluated_geometry import handoff_modifier, own_data
from ..data.pointcloud import (BASE, is_splat_object, plays_sequence, splats_from_pointcloud,
                               value_key)

try:
    from . import sequence_frames as sequence_runtime
except ImportError:  # the sequences layer is optional
    sequence_runtime = None


def splat_objects(depsgraph):
    """Evaluated splat objects that the depsgraph considers visible (view layer, collections)."""
    for obj in depsgraph.objects:
        if is_splat_object(obj):
            yield obj


def _sample(pointcloud, count: int, samples: int = 16) -> tuple:
    """A few values of the centres and colours, spread over the points (~0.15 ms): catches
    data replaced or rewritten without a depsgraph update we could see."""
    if count == 0:
        return ()
    index = np.unique(np.linspace(0, count - 1, samples).astype(np.int64))
    out = []
    for name in ("position", BASE):
        attribute = pointcloud.attributes.get(name)
        if attribute is not None:
            field = value_key(attribute)
            data = attribute.data
            out.extend(tuple(getattr(data[int(i)], field)) for i in index)
    return tuple(out)


class BaseCache:
    """SplatSets read from evaluated PointClouds, keyed by what makes them change.

    The key holds the data's name and point count, a version bumped by every depsgraph
    update that reports the PointCloud's geometry changed, and a sample of its values
    (for data replaced without an update we could see). Animated objects count too:
    measured (bpy 5.0), frame changes send no depsgraph_update_post, so playback re-reads
    nothing, while an edit of the data sends one. Objects sharing one PointCloud without
    modifiers (linked duplicates) share one entry; objects with modifiers have their own,
    also keyed by frame. Cached arrays are read-only: kernels and renderers never write them.

    The viewport (main thread) and a render thread share one cache: `lock` guards the
    dicts. bpy is read only outside it, by the thread that asked (each reads its own
    depsgraph), so a slow read never blocks the other thread's hits.
    """

    def __init__(self):
        self.lock = threading.Lock()
        self.versions: dict[str, int] = {}
        self.entries: dict[tuple, tuple] = {}

    def key(self, obj_eval, depsgraph) -> tuple:
        original = obj_eval.original
        data = own_data(obj_eval, depsgraph)
        data_name = data.original.name_full
        count = len(data.points)
        # with a handoff (5.3+) the object's own data is read, before any modifier
        modified = len(original.modifiers) > 0 and handoff_modifier(original) is None
        slot = ("object", original.name_full) if modified else ("data", data_name)
        frame = depsgraph.scene_eval.frame_float if modified else None
        with self.lock:
            version = self.versions.get(data_name, 0)
        return (slot, data_name, version, count, frame, hash(_sample(data, count)))

    def get(self, obj_eval, depsgraph):
        key = self.key(obj_eval, depsgraph)
        with self.lock:
            hit = self.entries.get(key[0])
        if hit is None or hit[0] != key:
            splats = splats_from_pointcloud(own_data(obj_eval, depsgraph))
            for name in ARRAYS:
                getattr(splats, name).flags.writeable = False
            hit = (key, splats)
            with self.lock:
                self.entries[key[0]] = hit
            self.prune()
        return hit[1], hit[0]

    def prune(self) -> None:
        """Let the data of deleted objects and PointClouds go (1M splats hold ~250 MB)."""
        alive = {("object", o.name_full) for o in bpy.data.objects}  # only after a read: rare
        alive |= {("data", d.name_full) for d in bpy.data.pointclouds}
        with self.lock:
            for slot in [s for s in self.entries if s not in alive]:
                del self.entries[slot]

    def on_update(self, depsgraph) -> None:
        changed = [u.id.original.name_full for u in depsgraph.updates
                   if isinstance(u.id, bpy.types.PointCloud) and u.is_updated_geometry]
        with self.lock:
            for name in changed:
                self.versions[name] = self.versions.get(name, 0) + 1

    def clear(self) -> None:
        with self.lock:
            self.entries.clear()
            self.versions.clear()


_BASE = BaseCache()
SPLAT_FIELDS = frozenset(ARRAYS)


def base_splats(obj_eval, depsgraph):
    """THE SEAM: (SplatSet, key) of an object before look and effects, at the depsgraph's
    frame. Equal keys mean identical splats. Sequence objects come from sequence_runtime."""
    if sequence_runtime is not None and plays_sequence(obj_eval):
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


def item_for(obj_eval, depsgraph=None, defer=None) -> RenderItem:
    """The RenderItem of one evaluated splat object.

    key: (name, base key) while the splats are the base data itself; with crop or effects,
    (name, base key, crop, effect signatures incl. time for time-driven effects), so equal
    keys mean equal splats and a renderer's per-key upload cache never shows a stale frame.
    defer(params) -> bool: the caller applies such effects (colour effects, a last morph,
    a displace) itself where the stack allows it (core.effects.deferral); they are then on
    item.deferred, not in its splats (but for the centres a deferred morph or displace
    moves: the caller sorts by them).
    """
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    world = np.array(obj_eval.matrix_world, np.float64)
    base, base_key = base_splats(obj_eval, depsgraph)
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
    on_cpu, deferred = split_stack(effects.params, defer) if defer else (effects.params, ())
    result = evaluate_stack(splats, on_cpu, time)
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
    settings = getattr(obj_eval, "splatline", None)
    if settings is None:
        return True
    look = settings.look
    if (plays_sequence(obj_eval) or any(effect.enabled for effect in settings.effects)
            or _crop(look) != (None, None)):
        return False
    # max_sh_degree tops out at 3, the most Splatline reads: no band is then cut
    return (look.visible and look.size == 1.0 and look.opacity == 1.0 and look.max_sh_degree >= 3
            and np.array_equal(_color_matrix(look), IDENTITY_COLOR))


def shown(obj_eval) -> bool:
    """False for objects whose Look > Show is off (evaluated, e.g. as morph targets, not drawn)."""
    look = getattr(getattr(obj_eval, "splatline", None), "look", None)
    return bool(getattr(look, "visible", True))


def collect_items(depsgraph, defer=None) -> list[RenderItem]:
    return [item_for(obj, depsgraph, defer) for obj in splat_objects(depsgraph) if shown(obj)]


def any_antialiased(depsgraph) -> bool:
    """Whether a splat object the frame draws is flagged as an anti-aliased capture
    (Object.splatline.antialiased, set on import from the file)."""
    return any(obj.splatline.antialiased for obj in splat_objects(depsgraph) if shown(obj))


@bpy.app.handlers.persistent
def _on_depsgraph_update(_scene, depsgraph):
    _BASE.on_update(depsgraph)


@bpy.app.handlers.persistent
def _on_load(*_args):
    _BASE.clear()
    effect_params.TARGETS.clear()
    BUFFERS.clear()  # kept output buffers (a morph's sh_rest) of the old file's splats


_HANDLERS = ((bpy.app.handlers.depsgraph_update_post, _on_depsgraph_update),
             (bpy.app.handlers.load_pre, _on_load))


def _on_unregister():
    _on_load()
    stop_helper()  # the effects' block thread (core/effects/common.for_blocks)


register, unregister = app_handlers(_HANDLERS, on_unregister=_on_unregister)
