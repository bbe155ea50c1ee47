"""Evaluated splats to files: export one frame, bake a frame range.

export_evaluated  the object's evaluated splats at the depsgraph's frame -> .ply / .splat,
                  with the look folded in (core/fold_look.py says exactly what is folded).
bake_frames       a frame range -> numbered PLYs that data/sequences.import_sequence reads back.
"""
from __future__ import annotations

import os

import bpy

from ...core import formats
from ...core.fold_look import baked_splats
from ...core.errors import SplatFormatError
from ..data.files import object_axes, write_in_format_axes
from .items import collect_items


def evaluated_item(obj, depsgraph):
    """evaluate.py's RenderItem for obj (matched by the item key's name_full: a linked
    object may share its .name with a local one)."""
    for item in collect_items(depsgraph):
        if item.key is not None and item.key[0] == obj.name_full and not item.instance:
            return item
    raise LookupError(f"object {obj.name!r} is not a visible splat object in the view layer")


def export_evaluated(obj, depsgraph, path, axes=None) -> None:
    """Write obj's evaluated splats at the depsgraph's frame to .ply or .splat, object-local."""
    fmt = formats.format_for_output(path)
    try:
        splats = baked_splats(evaluated_item(obj, depsgraph))
    except LookupError as exc:
        raise SplatFormatError(path, str(exc)) from None
    splats.axes = object_axes(obj, axes)  # axes: the data's frame where the object can't say
    if splats.count == 0:
        raise SplatFormatError(path, f"object {obj.name!r} has no splats at this frame")
    write_in_format_axes(path, fmt, splats)


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
