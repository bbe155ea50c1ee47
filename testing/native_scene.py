"""PointClouds laid out the way Blender 5.3's own splat importers leave them.

Facts from blender/blender (2026): io/common/intern/gsplat.cc writes, on the point domain,
`radiance:base` float4 (f_dc_0..2, sigmoid(opacity)), `scale` float3 (exp of the log scale),
`rotation` Quaternion (rot_0..3 as stored: the PLY importer does not normalize), and
`radiance:sh_k` float3 for k < (degree+1)^2 - 1, up to degree 4 (sh_0..sh_23);
ply_import_gsplat.cc then sets the PointCloud's type to GAUSSIAN_SPLAT (bpy 5.3.0: `type`).
The stand-in below does not set it: it adds cases on Blenders without native splats; the
real importers are tested in test_native_blender53.py. The object gets the file's
name and an identity transform (io/spz/importer/spz_import.cc), and no Splatline settings.

bpy cannot make a PointCloud of N points directly, so the positions go through a vertex-only
mesh and object.convert (what any Python code must do); everything else is written here with
plain attribute calls, independently of addon/blender/pointcloud.py.
"""
from __future__ import annotations

import numpy as np
import pytest


def value_field(attribute) -> str:
    """The element field of an attribute's values, asked of RNA (FLOAT4: `vector` in 5.1+)."""
    props = attribute.bl_rna.properties["data"].fixed_type.properties
    return next(k for k in ("value", "vector", "color") if k in props)


def _add(pointcloud, name, data_type, values):
    attribute = pointcloud.attributes.new(name, data_type, "POINT")
    attribute.data.foreach_set(value_field(attribute), np.ascontiguousarray(values, np.float32).ravel())
    return attribute


def has_float4(bpy) -> bool:
    return "FLOAT4" in bpy.types.Attribute.bl_rna.properties["data_type"].enum_items


def native_object(bpy, name, splats, band4=None, rotation_scale=2.0):
    """A splat object as Blender 5.3 imports `splats` (+ SH band 4 `band4`, (N, 9, 3)).
    Rotations are stored times rotation_scale, unnormalized like rot_0..3 of a PLY."""
    if not has_float4(bpy):
        pytest.skip("this Blender has no FLOAT4 attributes (5.3 writes radiance:base as float4)")
    n = splats.count
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(n)
    mesh.attributes["position"].data.foreach_set("vector", splats.positions.ravel())
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj],
                                   selected_editable_objects=[obj]):
        bpy.ops.object.convert(target="POINTCLOUD", keep_original=False)
    pc = obj.data
    for attribute in [a for a in pc.attributes if a.name != "position" and not a.is_required]:
        pc.attributes.remove(attribute)
    base = np.concatenate([splats.sh_dc, splats.opacities[:, None]], 1)
    _add(pc, "radiance:base", "FLOAT4", base)
    _add(pc, "scale", "FLOAT_VECTOR", splats.scales)
    _add(pc, "rotation", "QUATERNION", splats.rotations * rotation_scale)
    rest = splats.sh_rest if band4 is None else np.concatenate([splats.sh_rest, band4], 1)
    for k in range(rest.shape[1]):
        _add(pc, f"radiance:sh_{k}", "FLOAT_VECTOR", rest[:, k])
    pc.name = name
    return obj
