"""Dynamic-capture files -> one splat object that plays on the timeline (dynamic_source.py).

Several Spacetime segment files (one per 50 frames, as its training writes them) import as
one object that plays them in order. The file's axis convention goes on the object's
transform, as for any import (files.py). Where the file says nothing of its time, the
capture starts at the scene's start frame and plays in real time (seconds) or 50 frames a
segment; `frames_per_unit` overrides that.
"""
from __future__ import annotations

import os

import bpy

from ...core import budget
from ...core.axes import euler_for
from ...core.dynamic import read_dynamic, timeline
from . import dynamic_source
from .files import AXES_PROP, SOURCE_PROP, object_name
from .pointcloud import blender_bytes, new_pointcloud_object


def dynamic_blender_bytes(capture) -> int:
    """Blender's copy: the rest splats' attributes and the time model's own."""
    fields = sum(a.nbytes for a in dynamic_source.fields_of(capture).values())
    return blender_bytes(capture.count, capture.sh_degree) + fields


def import_dynamic(context, paths, *, axes="AUTO", frames_per_unit=None, start_frame=None,
                   collection=None):
    """Read one dynamic capture (a path, or a list of segment files played in order) into a
    new splat object named after its first file, active and selected. Raises
    SplatFormatError naming the file; on any failure nothing new is left in bpy.data."""
    paths = [paths] if isinstance(paths, (str, os.PathLike)) else list(paths)
    capture = read_dynamic(paths if len(paths) > 1 else paths[0])
    if axes != "AUTO":
        capture.axes = axes
    budget.check(paths[0], dynamic_blender_bytes(capture), "--max-memory",
                 f"{capture.count} dynamic splats as Blender attributes")
    scene = context.scene
    unit = dynamic_source.UNITS[capture.unit]
    if frames_per_unit is None:
        frames_per_unit = timeline.default_frames_per_unit(unit, scene.render.fps / scene.render.fps_base)
    if context.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    target = collection or context.collection or scene.collection
    obj = new_pointcloud_object(object_name(paths[0]), capture.rest(), target)
    try:
        dynamic_source.store(obj, capture, frames_per_unit,
                             scene.frame_start if start_frame is None else start_frame)
        obj.rotation_mode = "XYZ"
        obj.rotation_euler = euler_for(capture.axes)
        obj[SOURCE_PROP] = os.path.abspath(os.fspath(paths[0]))
        obj[AXES_PROP] = capture.axes
        view_layer = context.view_layer
        if view_layer is not None and obj.name in view_layer.objects:
            obj.select_set(True)
            view_layer.objects.active = obj
    except BaseException:
        pointcloud = obj.data
        bpy.data.objects.remove(obj)
        bpy.data.pointclouds.remove(pointcloud)
        raise
    return obj
