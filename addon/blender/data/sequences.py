"""Sequence import: the bpy-facing side of core/sequence.py behind ops/sequence.py.

import_sequence   a folder (or one numbered file of it) -> ONE object showing frame k at time t;
                  its PointCloud holds the first frame, the frames stay on disk.
Writing evaluated splats (export, bake) reads the evaluation, so it lives in evaluate/bake.py.
"""
from __future__ import annotations

import os

import bpy

from ...core import sequence as core_sequence
from .files import import_file

ALIGN_FILE_NUMBERS = "FILE_NUMBERS"   # file number N shows at scene frame N (a bake's round trip)
ALIGN_SCENE_START = "SCENE_START"     # the first file shows at the scene's start frame


def _stored_directory(directory: str) -> str:
    """Relative to the .blend ('//...') when the .blend is saved and on the same drive."""
    if not bpy.data.filepath:
        return directory
    try:
        return bpy.path.relpath(directory)
    except ValueError:  # another drive on Windows: no relative path exists
        return directory


def remap_directories(new_blend_path: str) -> dict:
    """Before a save to new_blend_path: re-express every sequence folder relative to it
    (Blender's own relative remap covers images and libraries, not add-on paths).
    Returns {object name: previous directory} so a save-as-copy can undo it."""
    if not bpy.context.preferences.filepaths.use_relative_paths:
        return {}
    start = os.path.dirname(os.path.abspath(new_blend_path))
    previous = {}
    for obj in bpy.data.objects:
        seq = getattr(getattr(obj, "splatline", None), "sequence", None)
        if seq is None or not seq.enabled or obj.library is not None or not seq.directory:
            continue
        absolute = bpy.path.abspath(seq.directory)  # against the .blend's current location
        try:
            relative = "//" + os.path.relpath(absolute, start).replace(os.sep, "/")
        except ValueError:  # another drive on Windows
            continue
        if not relative.endswith("/"):
            relative += "/"
        if relative != seq.directory:
            previous[obj.name] = seq.directory
            seq.directory = relative
    return previous


def restore_directories(previous: dict) -> None:
    for name, directory in previous.items():
        obj = bpy.data.objects.get(name)
        if obj is not None:
            obj.splatline.sequence.directory = directory


def _sequence_name(pattern) -> str:
    name = pattern.prefix.rstrip("_-. ")
    return name or os.path.basename(os.path.normpath(pattern.directory)) or "Splat Sequence"


def import_sequence(context, path, *, align=ALIGN_FILE_NUMBERS, loop_mode=core_sequence.HOLD,
                    set_scene_range=False, collection=None):
    """Import the sequence a folder or numbered file belongs to as one splat object.

    Raises SplatFormatError (no numbered files, or an unreadable first frame); on failure
    nothing new is left in bpy.data (import_file guarantees it for the first frame).
    """
    pattern = core_sequence.discover(os.path.abspath(bpy.path.abspath(os.fspath(path))))
    obj = import_file(context, pattern.path(0), collection=collection)
    obj.name = _sequence_name(pattern)
    obj.data.name = obj.name
    settings = obj.splatline.sequence
    settings.directory = _stored_directory(pattern.directory)
    settings.prefix, settings.suffix = pattern.prefix, pattern.suffix
    settings.digits, settings.first_number = pattern.digits, pattern.first
    settings.frame_count = pattern.count
    settings.start_frame = pattern.first if align == ALIGN_FILE_NUMBERS else context.scene.frame_start
    settings.loop_mode = loop_mode
    settings.enabled = True
    if set_scene_range:
        context.scene.frame_start = settings.start_frame
        context.scene.frame_end = settings.start_frame + pattern.count - 1
    return obj
