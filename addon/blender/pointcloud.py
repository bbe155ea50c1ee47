"""SplatSet <-> PointCloud data with Blender 5.3's splat attribute schema (DESIGN.md).

bpy 5.0 cannot resize a PointCloud from Python, so new point clouds are built as a
vertex-only mesh and converted; the attributes carry over unchanged.
"""
from __future__ import annotations

import numpy as np

import bpy

from ..core.splats import AXES_RDF, SplatSet, sh_coeff_count, sh_degree_for

BASE = "radiance:base"
_FLOAT4_TYPE = "FLOAT4" if "FLOAT4" in bpy.types.Attribute.bl_rna.properties["data_type"].enum_items else "FLOAT_COLOR"


def sh_name(k: int) -> str:
    return f"radiance:sh_{k}"


def is_splat_data(data) -> bool:
    return isinstance(data, bpy.types.PointCloud) and BASE in data.attributes


def _value_key(attribute) -> str:
    return {"FLOAT_VECTOR": "vector", "FLOAT_COLOR": "color", "QUATERNION": "value",
            "FLOAT4": "value", "FLOAT": "value"}[attribute.data_type]


def _set(attributes, name, data_type, values: np.ndarray):
    attribute = attributes.get(name) or attributes.new(name, data_type, "POINT")
    attribute.data.foreach_set(_value_key(attribute), np.ascontiguousarray(values, np.float32).ravel())


def _get(attributes, name, width, count) -> np.ndarray:
    attribute = attributes[name]
    out = np.empty(count * width, np.float32)
    attribute.data.foreach_get(_value_key(attribute), out)
    return out.reshape(count, width) if width > 1 else out


def _write_attributes(attributes, splats: SplatSet):
    _set(attributes, "scale", "FLOAT_VECTOR", splats.scales)
    _set(attributes, "rotation", "QUATERNION", splats.rotations)
    base = np.concatenate([splats.sh_dc, splats.opacities[:, None]], axis=1)
    _set(attributes, BASE, _FLOAT4_TYPE, base)
    for k in range(splats.sh_rest.shape[1]):
        _set(attributes, sh_name(k), "FLOAT_VECTOR", splats.sh_rest[:, k])


def new_pointcloud(name: str, splats: SplatSet) -> bpy.types.PointCloud:
    """A new PointCloud datablock holding splats (positions in the file's own frame).

    Nothing is left behind on failure: the helper mesh and object are always removed.
    """
    mesh = bpy.data.meshes.new(name)
    helper = None
    try:
        mesh.vertices.add(splats.count)
        mesh.vertices.foreach_set("co", np.ascontiguousarray(splats.positions, np.float32).ravel())
        _write_attributes(mesh.attributes, splats)
        helper = bpy.data.objects.new(name, mesh)
        pointcloud = _convert_to_pointcloud(helper)
    finally:
        if helper is not None:
            bpy.data.objects.remove(helper)
        if mesh.name in bpy.data.meshes and mesh.users == 0:
            bpy.data.meshes.remove(mesh)
    if ".select_vert" in pointcloud.attributes:
        pointcloud.attributes.remove(pointcloud.attributes[".select_vert"])
    pointcloud.name = name
    return pointcloud


def _convert_to_pointcloud(helper) -> bpy.types.PointCloud:
    # The convert operator works on a selected object linked into the view layer;
    # the caller removes the helper object afterwards, leaving the PointCloud datablock.
    bpy.context.scene.collection.objects.link(helper)
    with bpy.context.temp_override(active_object=helper, object=helper, selected_objects=[helper],
                                   selected_editable_objects=[helper]):
        bpy.ops.object.convert(target="POINTCLOUD", keep_original=False)
    if not isinstance(helper.data, bpy.types.PointCloud):
        raise RuntimeError("Blender did not convert the helper mesh to a PointCloud")
    return helper.data


def splats_from_pointcloud(pointcloud, axes: str = AXES_RDF) -> SplatSet:
    """Read the splat attributes of a (possibly evaluated) PointCloud into a SplatSet."""
    attributes = pointcloud.attributes
    n = len(pointcloud.points)
    base = _get(attributes, BASE, 4, n)
    k = 0
    while sh_name(k) in attributes:
        k += 1
    degree = sh_degree_for(_largest_complete(k))
    if n == 0:  # an empty PointCloud has no position attribute at all
        return SplatSet.allocate(0, degree, axes)
    rest = np.empty((n, sh_coeff_count(degree), 3), np.float32)
    for i in range(rest.shape[1]):
        rest[:, i] = _get(attributes, sh_name(i), 3, n)
    return SplatSet(
        positions=_get(attributes, "position", 3, n),
        scales=_get(attributes, "scale", 3, n),
        rotations=_get(attributes, "rotation", 4, n),
        opacities=np.ascontiguousarray(base[:, 3]),
        sh_dc=np.ascontiguousarray(base[:, :3]),
        sh_rest=rest,
        axes=axes,
    )


def _largest_complete(k: int) -> int:
    """Largest full-degree coefficient count <= k (a partial band is ignored)."""
    return max(c for c in (0, 3, 8, 15) if c <= k)
