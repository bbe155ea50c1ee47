"""What this Blender does with Gaussian splats by itself, found by asking RNA, never by version.

Blender 5.3 ships splats as a kind of PointCloud: `PointCloud.type` is an enum whose items
are `POINTS` and `GAUSSIAN_SPLAT` (measured on bpy 5.3.0). A PointCloud set to the splat item
is drawn by Workbench and EEVEE and ray-traced by Cycles, with meshes and lights; one left at
`POINTS` renders as black silhouettes in Cycles. Its importers (`wm.ply_import`,
`wm.spz_import`) write the attribute set Splatline uses (pointcloud.py) and set the splat
item. Blender builds without that enum item (4.5 .. 5.2) draw no splats natively.

Rules that follow (docs/ARCHITECTURE.md, "Blender versions"):
- a splat object is one whose data has `radiance:base`, whoever imported it;
- where the splat item exists, every splat PointCloud Splatline writes is set to it, so
  Blender's engines render Splatline's imports and Splatline's effects reach them
  (evaluate/handoff.py);
- Splatline's SpaceView3D overlay skips an object Blender draws natively, so it is never
  drawn twice; Splatline's own render engine draws every splat object, since under a custom
  engine Blender draws none.
"""
from __future__ import annotations

import bpy

SPLAT_TYPE_PROPERTY = "type"  # PointCloud.type in Blender 5.3 (items POINTS, GAUSSIAN_SPLAT)


def splat_type(rna=None) -> str | None:
    """Identifier of the PointCloud `type` item that makes Blender draw and render splats
    itself, or None where PointCloud has no such item (Blender before 5.3). `rna`: the
    struct to ask, bpy.types.PointCloud.bl_rna by default. The item is recognised by its
    identifier naming Gaussian splats, so a renamed or added item is not mistaken for it."""
    rna = bpy.types.PointCloud.bl_rna if rna is None else rna
    prop = rna.properties.get(SPLAT_TYPE_PROPERTY)
    if prop is None or prop.type != "ENUM":
        return None
    for item in prop.enum_items:
        if "GAUSSIAN" in item.identifier.upper() and "SPLAT" in item.identifier.upper():
            return item.identifier
    return None


def has_native_splats() -> bool:
    """True where this Blender draws and renders splat PointClouds itself."""
    return splat_type() is not None


def drawn_natively(data) -> bool:
    """True when Blender itself draws this PointCloud as splats (its type is the splat item).
    Asks the datablock's own RNA, so an evaluated copy answers as its original."""
    if not isinstance(data, bpy.types.PointCloud):
        return False
    mode = splat_type(data.bl_rna)
    return mode is not None and getattr(data, SPLAT_TYPE_PROPERTY, None) == mode


def mark_as_splats(data) -> bool:
    """Set a PointCloud Splatline wrote to Blender's splat type, where this Blender has one,
    so its own engines render it. Returns whether Blender now draws it natively."""
    mode = splat_type(data.bl_rna)
    if mode is None:
        return False
    if getattr(data, SPLAT_TYPE_PROPERTY) != mode:
        setattr(data, SPLAT_TYPE_PROPERTY, mode)
    return True


def native_importer(extension: str) -> str | None:
    """bpy.ops.wm operator name of Blender's own importer for a splat file extension, where
    this Blender has one (wm.ply_import: every build since 3.6; wm.spz_import: 5.3+)."""
    name = {".ply": "ply_import", ".spz": "spz_import"}.get(extension.lower())
    return name if name is not None and name in dir(bpy.ops.wm) else None
