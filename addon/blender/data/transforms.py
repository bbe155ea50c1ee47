"""Where an object is at a frame: the depsgraph's copy of it, and its world matrix, also
for an object the depsgraph does not evaluate (hidden: its evaluated copy is stale).

Blender data read for the effect stack (evaluate/effect_params.py) and for effect presets,
which measure an object's bounds where its effects will (data/effect_presets.py).
"""
from __future__ import annotations

import numpy as np

from ...core.effects.common import inverse
from .animation import channel_fcurves


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
    return inverse(world) @ other


def field_frame(world: np.ndarray, gizmo_world=None) -> np.ndarray:
    """A field's frame relative to the object (object <- field): the gizmo's, or without
    one world-aligned axes at the object's origin. Presets measure bounds in it too."""
    if gizmo_world is None:
        gizmo_world = np.eye(4)
        gizmo_world[:3, 3] = world[:3, 3]
    return relative_to(world, gizmo_world)
