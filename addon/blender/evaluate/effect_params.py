"""Blender effect items -> the core effect stack, at one frame of one depsgraph.

`stack` is the one place the stack is built: each active item's kind (core.effects.registry)
says which fields to read, how they become the kernel's params, and whether the frame's
cache key must hold the time (depends_on_time) and its positions key the effect
(moves_splats). Gizmo frames: an Empty's matrix relative to the splat object; without one,
world-aligned axes at the object's origin (so a plane's 'height' is world Z and units are
world units).
A SPLATS field (a morph target) is the other object's base splats mapped into the source
object's space and paired with the source's splats (cached: core.effects.morph.MorphCache).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core import effects as fx
from ...core.effects.morph import MorphCache
from ..data.sources import is_splat_object
from ..data.transforms import evaluated, field_frame, relative_to, world_matrix

TARGETS = MorphCache()  # SPLATS fields' splats, mapped and paired (cleared by items' handlers)


def gizmo_frame(effect, world: np.ndarray, depsgraph) -> np.ndarray:
    gizmo = world_matrix(effect.gizmo, depsgraph) if effect.gizmo is not None else None
    return field_frame(world, gizmo)


@dataclasses.dataclass
class EffectStack:
    params: list        # core params of the active effects, top of the stack first
    signature: tuple    # one per active effect; the time only where it depends on it
    moving: tuple       # the signatures of those that move splats


def stack(obj_eval, depsgraph, world, time: float, fps: float, source, source_key,
          splats_of) -> EffectStack:
    """The active effects of obj_eval at the depsgraph's frame. source/source_key: the splats
    the stack starts from; splats_of(obj_eval, depsgraph) -> (SplatSet, key) reads another
    object's base splats (for SPLATS fields). An effect whose SPLATS field holds no splat
    object is left out."""
    params, signatures, moving = [], [], []
    for effect in obj_eval.splatline.effects:
        if not effect.enabled or effect.amount <= 0.0:
            continue
        kind = fx.KINDS[effect.type]
        frame = gizmo_frame(effect, world, depsgraph)
        read = _values(effect, kind, (depsgraph, world, source, source_key, splats_of))
        if read is None:
            continue
        values, extra = read
        params.append(kind.make(values, fps, enabled=bool(effect.enabled),
                                amount=float(effect.amount), frame=frame))
        if kind.depends_on_time:
            extra += (time,)
        signatures.append(signature(params[-1], kind, extra))
        if kind.moves_splats:
            moving.append(signatures[-1])
    return EffectStack(params, tuple(signatures), tuple(moving))


def _values(effect, kind, where):
    """({field name: value}, key of what SPLATS fields read) of one item, or None."""
    values, extra = {}, ()
    for f in kind.fields:
        value = getattr(effect, f.name)
        if f.type == "COLOR":
            value = tuple(value)
        elif f.type == "SPLATS":
            value, key = _splats(value, *where)
            if value is None:
                return None
            extra += key
        values[f.name] = value
    return values, extra


def _splats(obj, depsgraph, world, source, source_key, splats_of):
    """((obj's splats in the source's space, their pairing), key), or (None, None)."""
    target = evaluated(obj, depsgraph)
    if target is None or not is_splat_object(target):
        return None, None
    target_splats, target_key = splats_of(target, depsgraph)
    relative = relative_to(world, world_matrix(target, depsgraph))
    mapped = TARGETS.target(source, source_key, target_splats, target_key, relative)
    return mapped, (target_key, relative.tobytes())


def signature(params, kind, extra=()) -> tuple:
    """Everything an effect's output depends on besides the input splats and time: the
    fields of the core parameters the kernel reads (not the panel's property list, which
    can miss a derived value such as Explode's start in seconds = start frame / fps).
    The kind's opaque params (a morph's target and pairing) are identified by `extra`
    (target key, relative matrix)."""
    values = [type(params).__name__]
    for spec in dataclasses.fields(params):
        if spec.name in kind.opaque:
            continue
        value = getattr(params, spec.name)
        values.append(value.tobytes() if isinstance(value, np.ndarray) else value)
    return tuple(values) + tuple(extra)
