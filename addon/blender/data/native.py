"""What this Blender does with Gaussian splats by itself, found by asking RNA, never by version.

Blender 5.3 (source: io/ply/importer/ply_import_gsplat.cc, io/common/intern/gsplat.cc,
io/spz/) imports 3DGS captures as PointClouds holding the attribute set Splatline uses
(pointcloud.py: `radiance:base` FLOAT4, `scale`, `rotation`, `radiance:sh_k` up to degree 4)
and marks them with `PointCloud.render_as = PT_RENDER_AS_SPLATS`, which makes Blender's own
draw engines draw them. The Python name of that enum is not public yet, so the splat mode is
found as the `render_as` item whose identifier names splats. Blender builds without that
property (4.5 .. 5.2) draw no splats natively.

Rules that follow (docs/ARCHITECTURE.md, "Blender versions"):
- a splat object is one whose data has `radiance:base`, whoever imported it;
- Splatline's SpaceView3D overlay skips an object Blender draws natively, so it is never drawn
  twice; Splatline's own render engine draws every splat object, since under a custom engine
  Blender draws none.
"""
from __future__ import annotations

import bpy

RENDER_AS = "render_as"  # RNA property of PointCloud in Blender 5.3+ (DNA: PointCloud.render_as)


def splat_render_mode(rna=None) -> str | None:
    """Identifier of the PointCloud `render_as` item that makes Blender draw splats itself,
    or None where PointCloud has no such enum (Blender before 5.3). `rna`: the struct to ask,
    bpy.types.PointCloud.bl_rna by default."""
    rna = bpy.types.PointCloud.bl_rna if rna is None else rna
    prop = rna.properties.get(RENDER_AS)
    if prop is None or prop.type != "ENUM":
        return None
    for item in prop.enum_items:
        if "SPLAT" in item.identifier.upper():
            return item.identifier
    return None


def drawn_natively(data) -> bool:
    """True when Blender itself draws this PointCloud as splats (its render_as is the splat
    mode). Asks the datablock's own RNA, so an evaluated copy answers as its original."""
    mode = splat_render_mode(data.bl_rna) if hasattr(data, "bl_rna") else None
    return mode is not None and getattr(data, RENDER_AS, None) == mode


def native_importer(extension: str) -> str | None:
    """bpy.ops.wm operator name of Blender's own importer for a splat file extension, where
    this Blender has one (wm.ply_import: every build since 3.6; wm.spz_import: 5.3+)."""
    name = {".ply": "ply_import", ".spz": "spz_import"}.get(extension.lower())
    return name if name is not None and name in dir(bpy.ops.wm) else None
