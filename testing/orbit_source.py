"""A throwaway splat source, declared by its row alone (addon/blender/data/sources.py): an
object with an `orbit_rate` custom property shows its stored splats turned about its own z
axis by rate x seconds, every frame, with no keyframe. Positions and orientations turn
together, as a turned object would show them (the tests use degree-0 captures, whose
colour ignores the view direction)."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from addon.blender.data import stored_splats
from addon.blender.data.source_kind import SourceFrame, SplatSource
from addon.core import quaternion

PROPERTY = "orbit_rate"


def applies(obj) -> bool:
    # custom properties live on the original: an evaluated copy lists none
    return PROPERTY in obj.original.keys()


def angle(obj, seconds: float) -> float:
    return float(obj.original[PROPERTY]) * seconds


def turned(splats, radians: float):
    """The splats turned by `radians` about z: the readable meaning of a frame."""
    c, s = math.cos(radians), math.sin(radians)
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]], np.float32)
    q = np.array([[math.cos(radians / 2), 0.0, 0.0, math.sin(radians / 2)]], np.float32)
    rotations = quaternion.multiply(np.repeat(q, splats.count, axis=0), splats.rotations)
    return replace(splats, positions=splats.positions @ turn.T, rotations=rotations)


def frame(obj_eval, depsgraph) -> SourceFrame:
    scene = depsgraph.scene_eval
    seconds = scene.frame_float * scene.render.fps_base / scene.render.fps
    rest, key = stored_splats.CACHE.get(obj_eval, depsgraph)
    radians = angle(obj_eval, seconds)
    return SourceFrame(turned(rest, radians), ("orbit", key, radians), rest=rest.positions)


ROW = SplatSource("TEST_ORBIT", "Orbit", applies, frame, depends_on_time=True,
                  moves_splats=True)
