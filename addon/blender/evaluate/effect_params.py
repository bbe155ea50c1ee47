"""Blender effect items -> core effect parameters, at one frame of one depsgraph.

Gizmo frames: an Empty's matrix relative to the splat object; without one, world-aligned
axes at the object's origin (so a plane's 'height' is world Z and units are world units).
Morph targets are the target object's base splats mapped into the source object's space.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core import effects as fx
from ..data.animation import channel_fcurves

POSITION_TYPES = {"DISPLACE", "EXPLODE", "TWIST", "MORPH"}
TIME_TYPES = {"DISPLACE", "EXPLODE"}  # the others depend on time only through keyframes


def evaluated(obj, depsgraph):
    """The depsgraph's copy of obj (stale for hidden objects: see world_matrix)."""
    if obj is None:
        return None
    try:
        return obj.original.evaluated_get(depsgraph)
    except (RuntimeError, ReferenceError):
        return obj


def shown_in(obj, depsgraph) -> bool:
    """Whether the depsgraph evaluates obj (hidden objects keep a stale evaluated copy)."""
    name = obj.original.name_full
    return any(o.original.name_full == name for o in depsgraph.objects)


def world_matrix(obj, depsgraph) -> np.ndarray:
    """obj's world matrix at the depsgraph's frame. For an object the depsgraph does not
    evaluate (hidden; its evaluated copy is stale) the matrix is rebuilt from its keyframed
    location/rotation/scale at the frame and its parents' (constraints and drivers of
    hidden objects are not evaluated)."""
    if shown_in(obj, depsgraph):
        return np.array(evaluated(obj, depsgraph).matrix_world, np.float64)
    local = basis_at(obj, depsgraph.scene_eval.frame_float)
    if obj.parent is None:
        return local
    return world_matrix(obj.parent, depsgraph) @ np.array(obj.matrix_parent_inverse, np.float64) @ local


def _transform_curves(obj) -> dict:
    """{(data_path, index): F-curve} of obj's own transform channels."""
    wanted = {"location", "rotation_euler", "rotation_quaternion", "scale"}
    return {(c.data_path, c.array_index): c for c in channel_fcurves(obj)
            if c.data_path in wanted and not c.mute}


def basis_at(obj, frame: float) -> np.ndarray:
    """obj's local matrix at `frame`: its keyframed location/rotation/scale evaluated there
    (un-keyed channels keep their stored values). For objects no depsgraph evaluates."""
    from mathutils import Euler, Matrix, Quaternion, Vector

    curves = _transform_curves(obj)

    def channel(path, current):
        return [curves[(path, i)].evaluate(frame) if (path, i) in curves else v
                for i, v in enumerate(current)]

    location = Vector(channel("location", obj.location))
    scale = channel("scale", obj.scale)
    if obj.rotation_mode == "QUATERNION":
        rotation = Quaternion(channel("rotation_quaternion", obj.rotation_quaternion)).normalized()
    elif obj.rotation_mode == "AXIS_ANGLE":
        angle, *axis = obj.rotation_axis_angle
        rotation = Quaternion(Vector(axis), angle)
    else:
        rotation = Euler(channel("rotation_euler", obj.rotation_euler), obj.rotation_mode).to_quaternion()
    matrix = Matrix.LocRotScale(location, rotation, Vector(scale))
    return np.array(matrix, np.float64)


def relative_to(world: np.ndarray, other: np.ndarray) -> np.ndarray:
    """inv(world) @ other, also for a singular world (an object scaled to 0)."""
    return fx.common.inverse(world) @ other


def gizmo_frame(effect, world: np.ndarray, depsgraph) -> np.ndarray:
    gizmo = world_matrix(effect.gizmo, depsgraph) if effect.gizmo is not None else None
    return field_frame(world, gizmo)


def field_frame(world: np.ndarray, gizmo_world=None) -> np.ndarray:
    """A field's frame relative to the object (object <- field): the gizmo's, or without
    one world-aligned axes at the object's origin. Presets measure bounds in it too."""
    if gizmo_world is None:
        gizmo_world = np.eye(4)
        gizmo_world[:3, 3] = world[:3, 3]
    return relative_to(world, gizmo_world)


def _stops(effect):
    stops = [(0.0, tuple(effect.color_a)), (1.0, tuple(effect.color_b))]
    if effect.use_color_mid:
        stops.insert(1, (float(effect.mid_position), tuple(effect.color_mid)))
    return tuple(stops)


def build(effect, frame: np.ndarray, fps: float, morph_target=None):
    """Core params for one enabled effect item (morph_target: (SplatSet, Pairing) or None)."""
    common = dict(enabled=bool(effect.enabled), amount=float(effect.amount), frame=frame)
    kind = effect.type
    if kind == "REVEAL":
        return fx.Reveal(**common, shape=effect.reveal_shape, progress=effect.progress,
                         width=effect.edge_width, invert=effect.invert, shrink=effect.shrink,
                         glow_color=tuple(effect.glow_color), glow_strength=effect.glow_strength,
                         frequency=effect.frequency, seed=effect.seed)
    if kind == "DISPLACE":
        return fx.Displace(**common, amplitude=effect.amplitude, frequency=effect.frequency,
                           speed=effect.speed, seed=effect.seed)
    if kind == "EXPLODE":
        return fx.Explode(**common, mode=effect.explode_mode, strength=effect.strength,
                          spread=effect.spread, spin=effect.spin, gravity=effect.gravity,
                          start=effect.start_frame / fps, fade=effect.fade, seed=effect.seed)
    if kind == "TWIST":
        return fx.Twist(**common, twist=effect.twist, swirl=effect.swirl, radius=effect.swirl_radius)
    if kind == "GRADE":
        return fx.Grade(**common, field=effect.grade_field, stops=_stops(effect),
                        low=effect.range_low, high=effect.range_high, mode=effect.grade_mode,
                        frequency=effect.frequency, seed=effect.seed)
    if kind == "MORPH":
        target, pairing = morph_target if morph_target is not None else (None, None)
        return fx.Morph(**common, target=target, pairing=pairing)
    raise ValueError(f"unknown effect type {kind!r}")


def signature(params, extra=()) -> tuple:
    """Everything an effect's output depends on besides the input splats and time: the
    fields of the core parameters the kernel reads (not the panel's property list, which
    can miss a derived value such as Explode's start in seconds = start frame / fps).
    A morph's target and pairing are identified by `extra` (target key, relative matrix)."""
    values = [type(params).__name__]
    for spec in dataclasses.fields(params):
        if spec.name in ("target", "pairing"):
            continue
        value = getattr(params, spec.name)
        values.append(value.tobytes() if isinstance(value, np.ndarray) else value)
    return tuple(values) + tuple(extra)
