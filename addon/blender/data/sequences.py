"""Sequence import, evaluated export and bake: the bpy-facing functions behind sequence_ops.

import_sequence   a folder (or one numbered file of it) -> ONE object showing frame k at time t;
                  its PointCloud holds the first frame, the frames stay on disk.
export_evaluated  the object's evaluated splats at the depsgraph's frame -> .ply / .splat,
                  with the look folded in (core/bake.py says exactly what is folded).
bake_frames       a frame range -> numbered PLYs that import_sequence reads back.
"""
from __future__ import annotations

import os

import bpy

from ...core import formats
from ...core import sequence as core_sequence
from ...core.bake import baked_splats
from ...core.errors import SplatFormatError
from ...core.reframe import reframe
from ..evaluate.items import collect_items
from .files import WRITE_AXES, import_file, object_axes

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


def evaluated_item(obj, depsgraph):
    """evaluate.py's RenderItem for obj (matched by the item key's name_full: a linked
    object may share its .name with a local one)."""
    for item in collect_items(depsgraph):
        if item.key is not None and item.key[0] == obj.name_full:
            return item
    raise LookupError(f"object {obj.name!r} is not a visible splat object in the view layer")


def export_evaluated(obj, depsgraph, path) -> None:
    """Write obj's evaluated splats at the depsgraph's frame to .ply or .splat, object-local."""
    fmt = formats.format_for_output(path)
    try:
        splats = baked_splats(evaluated_item(obj, depsgraph))
    except LookupError as exc:
        raise SplatFormatError(path, str(exc)) from None
    splats.axes = object_axes(obj)
    if splats.count == 0:
        raise SplatFormatError(path, f"object {obj.name!r} has no splats at this frame")
    formats.write(path, reframe(splats, WRITE_AXES[fmt]), fmt)


def bake_paths(directory, frame_start, frame_end, prefix="frame_", digits=4, ext=".ply"):
    return [(f, os.path.join(directory, f"{prefix}{str(f).zfill(digits)}{ext}"))
            for f in range(frame_start, frame_end + 1)]


def bake_frames(context, obj, directory, frame_start, frame_end, prefix="frame_", digits=4):
    """Write one numbered PLY per scene frame; a generator yielding (frame, path) after each,
    so an operator can show progress and stop between frames. The scene's frame is restored
    when the generator finishes or is closed."""
    if frame_end < frame_start:
        raise ValueError(f"empty frame range {frame_start}..{frame_end}")
    if frame_start < 0:
        raise ValueError("bake frames are file numbers and cannot be negative")
    directory = bpy.path.abspath(directory)
    os.makedirs(directory, exist_ok=True)
    scene = context.scene
    restore = (scene.frame_current, scene.frame_subframe)
    try:
        for frame, path in bake_paths(directory, frame_start, frame_end, prefix, digits):
            scene.frame_set(frame)
            export_evaluated(obj, context.evaluated_depsgraph_get(), path)
            yield frame, path
    finally:
        scene.frame_set(restore[0], subframe=restore[1])
