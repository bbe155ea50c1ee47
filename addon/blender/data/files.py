"""Splat files <-> splat objects: the bpy-facing import and export used by the operators,
the command line and the other parts of the add-on.

A splat object is a POINTCLOUD object with the DESIGN.md attribute schema. Its data stays
in the file's own frame; the file's axis convention is the object's rotation. The source
path and convention are kept as custom properties so export can write the same frame.
"""
from __future__ import annotations

import os

import bpy

from ...core import budget, formats
from ...core.axes import euler_for
from ...core.errors import SplatFormatError
from ...core.reframe import reframe
from ...core.splats import AXES, AXES_RDF
from .native import drawn_natively
from .pointcloud import blender_bytes, new_pointcloud_object, splats_from_pointcloud

SOURCE_PROP = "splatline_source"
AXES_PROP = "splatline_axes"
AXES_ITEMS = ("AUTO",) + AXES
BAD_POLICIES = ("fix", "drop", "error")


def read_for_import(path, *, max_sh_degree=3, min_opacity=0.0, max_count=0, bad="fix", max_splats=None,
                    lod=None):
    """(SplatSet, ReadReport) after the import options. max_count 0 means no limit;
    max_splats is the reader's splat budget, lod the level of detail of a file holding several
    (a streamed SOG, an LCC or LCC2 scene; formats.read_with_report; None: the finest).
    A file, or a selection, with no splats is an error: there would be nothing to animate."""
    if bad not in BAD_POLICIES:
        raise ValueError(f"bad-value policy {bad!r} is not one of {BAD_POLICIES}")
    splats, report = formats.read_with_report(
        path, sh_degree=max_sh_degree, min_opacity=min_opacity if min_opacity > 0 else None,
        max_count=max_count if max_count > 0 else None, bad=bad, max_splats=max_splats, lod=lod)
    if report.count_in_file == 0:
        raise SplatFormatError(path, "holds no splats (0 vertices)")
    if splats.count == 0:
        raise SplatFormatError(path, f"no splats left after the import options (min opacity "
                                     f"{min_opacity:g}, max count {max_count}) of {report.count_in_file}")
    return splats, report


def object_name(path) -> str:
    path = os.fspath(path)
    if os.path.basename(path).lower() in ("meta.json", "lod-meta.json"):  # a SOG folder: its name
        path = os.path.dirname(os.path.abspath(path))
    return os.path.splitext(os.path.basename(path))[0] or "Splats"


def import_file_with_report(context, path, *, max_sh_degree=3, min_opacity=0.0, max_count=0,
                            axes="AUTO", collection=None, bad="fix", progress=None, max_splats=None,
                            lod=None):
    """import_file, also returning the reader's ReadReport (bad-value counts, file degree).
    progress, if given, is called with the fraction done (0..1) after each stage."""
    if axes not in AXES_ITEMS:
        raise ValueError(f"axes {axes!r} is not one of {AXES_ITEMS}")
    splats, report = read_for_import(path, max_sh_degree=max_sh_degree, min_opacity=min_opacity,
                                     max_count=max_count, bad=bad, max_splats=max_splats, lod=lod)
    if progress is not None:
        progress(0.6)  # reading is about 60% of an import (bench/import_bench.py, read column)
    if axes != "AUTO":
        splats.axes = axes
    if max_splats is None:  # Blender's copy of the splats, on top of what reading holds
        budget.check(path, blender_bytes(splats.count, splats.sh_degree), "--max-memory",
                     f"{splats.count} splats of SH degree {splats.sh_degree} as Blender attributes")
    if context.mode != "OBJECT":  # Blender's convert operator, used to build it, needs object mode
        bpy.ops.object.mode_set(mode="OBJECT")
    target = collection or context.collection or context.scene.collection
    obj = new_pointcloud_object(object_name(path), splats, target)
    try:
        obj.rotation_mode = "XYZ"
        obj.rotation_euler = euler_for(splats.axes)
        obj[SOURCE_PROP] = os.path.abspath(os.fspath(path))
        obj[AXES_PROP] = splats.axes
        obj.splatline.antialiased = splats.antialiased
        if splats.antialiased and drawn_natively(obj.data):  # 5.3: handed to Blender's engines
            print(f"{obj.name}: trained with anti-aliasing; Blender's own engines have no "
                  "anti-aliased splat mode (the Splatline engine renders it with the compensation)")
        _make_active(context, obj)
    except BaseException:
        pointcloud = obj.data
        bpy.data.objects.remove(obj)
        bpy.data.pointclouds.remove(pointcloud)
        raise
    if progress is not None:
        progress(1.0)
    return obj, report


def import_file(context, path, *, max_sh_degree=3, min_opacity=0.0, max_count=0, axes="AUTO",
                collection=None, bad="fix") -> bpy.types.Object:
    """Read a splat file into a new PointCloud object named after the file, linked into
    `collection` (default: the active one), active and selected.

    Options: SH degree cap (no sh attributes above it are stored), opacity prune, count
    limit by importance (0 = none), axis convention override ("AUTO" = the file's), and the
    NaN/Inf policy ("fix", "drop", "error"). Raises SplatFormatError naming the file; on any
    failure nothing new is left in bpy.data.
    """
    return import_file_with_report(
        context, path, max_sh_degree=max_sh_degree, min_opacity=min_opacity, max_count=max_count,
        axes=axes, collection=collection, bad=bad)[0]


def _make_active(context, obj) -> None:
    view_layer = context.view_layer
    if view_layer is None or obj.name not in view_layer.objects:
        return  # linked into an excluded collection: nothing to select
    obj.select_set(True)
    view_layer.objects.active = obj


def object_axes(obj, axes=None) -> str:
    """The axis convention the object's data is in: what export re-expresses in each
    format's own frame (formats.WRITE_AXES: RDF for every writer), so the written file
    means what the object shows.

    - `axes`, when given (the export operator's Data Axes, `convert --axes`), wins: the
      caller knows better.
    - A Splatline import records its file's convention (AXES_PROP) beside the rotation it
      puts on the transform: that is the frame of its data.
    - An object without that property is Blender's own: "RDF", the frame of a 3DGS PLY.
      `wm.ply_import` (5.3, default Forward Y / Up Z, i.e. no turn) stores the file's values
      with an identity transform, so they are written back unchanged: exporting it to .ply
      gives the file's splats again (tests/blender/data/test_native_export.py).
    - `wm.spz_import` (5.3) turns the data to Blender's frame itself (the file read as RUB,
      positions to (x, -z, y), rotations and SH bands turned alike: measured equal to
      core.reframe RUB -> RFU to float32 rounding), so its data is "RFU". Its objects carry
      no mark that tells them from wm.ply_import's (measured on 5.3.0: the same four
      attribute kinds, identity transform, no custom properties, no operator record in
      background mode), so their frame has to be said: axes="RFU" here, or the object's
      `splatline_axes` property set to "RFU". Written as RFU data, the file shows in a
      Splatline import what Blender showed (the same world positions).
    """
    if axes is not None:
        if axes not in AXES:
            raise ValueError(f"axes {axes!r} is not one of {AXES}")
        return axes
    stored = obj.get(AXES_PROP, AXES_RDF)
    return stored if stored in AXES else AXES_RDF


def object_splats(obj, evaluated=False, depsgraph=None, axes=None):
    """The object's splats in its data's frame (object_axes): stored data, or evaluated
    (modifiers) data."""
    data = obj.data
    if evaluated:
        depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
        data = obj.evaluated_get(depsgraph).data
    splats = splats_from_pointcloud(data, object_axes(obj, axes))
    splats.antialiased = bool(getattr(getattr(obj, "splatline", None), "antialiased", False))
    return splats


def export_object(obj, path, evaluated=False, depsgraph=None, axes=None) -> list:
    """Write a splat object's data in the format its path names, object-local (the object's transform,
    which carries the axis convention, is not applied). Data stored in another convention
    than the format's is re-expressed in the format's; `axes` says which convention the data
    is in where the object cannot (object_axes). Works on any splat object: Splatline's
    imports and Blender 5.3's own (wm.ply_import, wm.spz_import). Raises SplatFormatError."""
    fmt = formats.format_for_output(path)
    splats = object_splats(obj, evaluated, depsgraph, axes)
    if splats.count == 0:
        raise SplatFormatError(path, f"object {obj.name!r} holds no splats to export")
    return write_in_format_axes(path, fmt, splats)


def write_in_format_axes(path, fmt: str, splats) -> list:
    """Write splats as `fmt`, re-expressed in that format's axis convention (its row in the
    format table) from the one they carry; returns the writer's notes (formats.write)."""
    return formats.write(path, reframe(splats, formats.table.row(fmt).axes), fmt)
