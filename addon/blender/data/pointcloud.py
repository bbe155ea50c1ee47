"""SplatSet <-> PointCloud data with Blender 5.3's splat attribute schema (DESIGN.md).

bpy 5.0 cannot resize a PointCloud from Python, so a new point cloud starts as a
vertex-only mesh holding only the positions, which bpy.ops.object.convert turns into a
PointCloud (cheap: Blender shares the array). The splat attributes are then written on
the PointCloud itself, where `attributes.new` allocates lazily, so each array is written
once by foreach_set from a contiguous float32 buffer and never zero-filled first.
"""
from __future__ import annotations

import logging

import numpy as np

import bpy

from ...core import stop
from ...core.formats._common import normalize_quats_
from ...core.splats import AXES_RDF, SplatSet, sh_coeff_count, sh_degree_for
from .native import mark_as_splats

BASE = "radiance:base"
# On the object that holds another splat object's evaluated splats for Blender's engines
# (evaluated_geometry.py): it is that object's output, not a splat object of its own.
COMPANION_MARK = "splatline_evaluated_of"
# On a splat object's shadow caster in the mesh scene (render/shadow_casters.py): it shows
# that object's splats to Blender's engines for shadows only; no splat object of its own.
CASTER_MARK = "splatline_shadow_caster"
log = logging.getLogger("splatline")
_FLOAT4_TYPE = "FLOAT4" if "FLOAT4" in bpy.types.Attribute.bl_rna.properties["data_type"].enum_items else "FLOAT_COLOR"
_VALUE_KEYS: dict[str, str] = {}


def value_key(attribute) -> str:
    """The field that holds an attribute's values (foreach key, element attribute), asked of
    RNA rather than tabulated per Blender version: FLOAT4 values are `vector` in 5.1+ (the
    element struct is Float4AttributeValue), colours `color`, quaternions and floats `value`."""
    key = _VALUE_KEYS.get(attribute.data_type)
    if key is None:
        props = attribute.bl_rna.properties["data"].fixed_type.properties
        key = next(k for k in ("value", "vector", "color") if k in props)
        _VALUE_KEYS[attribute.data_type] = key
    return key


def sh_name(k: int) -> str:
    return f"radiance:sh_{k}"


def is_splat_data(data) -> bool:
    return isinstance(data, bpy.types.PointCloud) and BASE in data.attributes


def schema(degree: int) -> list[tuple[str, str]]:
    """(name, data type) of every attribute a splat PointCloud of this SH degree holds."""
    names = [("position", "FLOAT_VECTOR"), ("scale", "FLOAT_VECTOR"), ("rotation", "QUATERNION"),
             (BASE, _FLOAT4_TYPE)]
    return names + [(sh_name(k), "FLOAT_VECTOR") for k in range(sh_coeff_count(degree))]


def _contiguous(values: np.ndarray) -> np.ndarray:
    """A C-contiguous float32 view, or a copy only when the layout needs one."""
    if values.dtype == np.float32 and values.flags.c_contiguous:
        return values
    return np.ascontiguousarray(values, np.float32)


def _set(attributes, name, data_type, values: np.ndarray):
    attribute = attributes.get(name)
    if attribute is not None and attribute.data_type != data_type:
        attributes.remove(attribute)
        attribute = None
    if attribute is None:
        attribute = attributes.new(name, data_type, "POINT")
    flat = _contiguous(values).reshape(-1)
    attribute.data.foreach_set(value_key(attribute), flat)


_FLOAT_TYPES = {1: "FLOAT", 2: "FLOAT2", 3: "FLOAT_VECTOR", 4: _FLOAT4_TYPE}


def write_floats(attributes, name: str, values: np.ndarray) -> None:
    """A point attribute of 1 to 4 floats a point (a dynamic capture's own fields)."""
    width = 1 if values.ndim == 1 else values.shape[1]
    _set(attributes, name, _FLOAT_TYPES[width], values)


def read_floats(attributes, name: str, width: int, count: int) -> np.ndarray:
    return _get(attributes, name, width, count)


def _get(attributes, name, width, count) -> np.ndarray:
    attribute = attributes[name]
    out = np.empty(count * width, np.float32)
    attribute.data.foreach_get(value_key(attribute), out)
    return out.reshape(count, width) if width > 1 else out


def swap01(a: np.ndarray, block: int = 4096) -> np.ndarray:
    """C-contiguous float32 copy of an (A, B, 3) array with its first two axes swapped.

    Each 3-float row moves as one 12-byte item, block by block along the long axis. A plain
    strided transpose between (N, K, 3) and (K, N, 3), or K copies of one plane each, pull
    every cache line K times: for 1M splats at degree 3 measured 0.43 s per plane, 0.23 s
    blocked by floats, 0.09 s blocked by 12-byte items."""
    if a.dtype != np.float32 or a.strides[2] != 4:
        a = np.ascontiguousarray(a, np.float32)
    item = np.dtype((np.void, 4 * a.shape[2]))
    out = np.empty((a.shape[1], a.shape[0], a.shape[2]), np.float32)
    if out.size == 0:
        return out
    src, dst = a.view(item)[..., 0], out.view(item)[..., 0]
    if a.shape[0] >= a.shape[1]:
        for i in range(0, a.shape[0], block):
            np.copyto(dst[:, i:i + block], src[i:i + block].T)
    else:
        for i in range(0, a.shape[1], block):
            np.copyto(dst[i:i + block], src[:, i:i + block].T)
    return out


def per_coefficient(rest: np.ndarray) -> np.ndarray:
    """(N, K, 3) higher SH -> (K, N, 3) with each rest[:, k] contiguous, as foreach_set needs.
    Zero-copy when the reader already stores coefficient planes (formats/ply.py does)."""
    planes = rest.transpose(1, 0, 2)
    if planes.flags.c_contiguous and planes.dtype == np.float32:
        return planes
    return swap01(rest)


def write_attributes(attributes, splats: SplatSet, unchanged=frozenset()) -> None:
    """Every splat attribute except position, on a geometry with splats.count points.
    sh attributes beyond the set's degree are removed, so a lower degree leaves none behind.
    `unchanged` names SplatSet fields the geometry already holds ("scales", "rotations",
    "base" for opacities and sh_dc together, "sh_rest"): those are not written again."""
    if "scales" not in unchanged:
        _set(attributes, "scale", "FLOAT_VECTOR", splats.scales)
    if "rotations" not in unchanged:
        _set(attributes, "rotation", "QUATERNION", splats.rotations)
    if "base" not in unchanged:
        base = np.empty((splats.count, 4), np.float32)
        base[:, :3] = splats.sh_dc
        base[:, 3] = splats.opacities
        _set(attributes, BASE, _FLOAT4_TYPE, base)
    k = sh_coeff_count(splats.sh_degree)
    if "sh_rest" not in unchanged:
        rest = per_coefficient(splats.sh_rest)
        for i in range(k):
            _set(attributes, sh_name(i), "FLOAT_VECTOR", rest[i])
    while sh_name(k) in attributes:
        attributes.remove(attributes[sh_name(k)])
        k += 1


def blender_bytes(count: int, sh_degree: int) -> int:
    """What new_pointcloud_object adds at its peak for `count` splats of `sh_degree`: each
    attribute as float32 in Blender (14 floats a splat and 3 per higher SH coefficient),
    as much again in the contiguous copies foreach_set is given (per_coefficient copies
    the whole higher SH), and 64 bytes for the helper mesh's vertex and Blender's own
    per-point data. Measured on bpy 5.0 (VmHWM over the call, 400,000 random splats):
    385 bytes a splat at degree 3 (this estimate: 536), 97 at degree 1 (248), 25 at 0 (176)."""
    return blender_bytes_for(count, 3 * sh_coeff_count(sh_degree))


def blender_bytes_for(count: int, rest_floats: int) -> int:
    """blender_bytes by the higher-SH floats per splat (core/budget.after_read's terms)."""
    return int(count) * (2 * 4 * (14 + int(rest_floats)) + 64)


def new_pointcloud(name: str, splats: SplatSet) -> bpy.types.PointCloud:
    """A new PointCloud datablock (no object) holding splats in the file's own frame.

    Atomic: on any failure the helper mesh, helper object and PointCloud are removed.
    """
    obj = new_pointcloud_object(name, splats)
    pointcloud = obj.data
    bpy.data.objects.remove(obj)
    return pointcloud


def new_pointcloud_object(name: str, splats: SplatSet, collection=None) -> bpy.types.Object:
    """A new object holding a new splat PointCloud, linked into `collection` (default: the
    scene's master collection). Atomic: on failure no object, mesh or PointCloud is left."""
    mesh = bpy.data.meshes.new(name)
    obj = pointcloud = None
    try:
        mesh.vertices.add(splats.count)
        if splats.count:
            mesh.attributes["position"].data.foreach_set("vector", _contiguous(splats.positions).reshape(-1))
        obj = bpy.data.objects.new(name, mesh)
        pointcloud = _convert_to_pointcloud(obj)
        _fill(pointcloud, splats)
        mark_as_splats(pointcloud)  # Blender 5.3+: its own engines render it too
        pointcloud.name = name
        _relink(obj, collection)
    except BaseException:
        if obj is not None:
            bpy.data.objects.remove(obj)
        if pointcloud is not None and pointcloud.name in bpy.data.pointclouds:
            bpy.data.pointclouds.remove(pointcloud)
        raise
    finally:
        if mesh.name in bpy.data.meshes and mesh.users == 0:
            bpy.data.meshes.remove(mesh)
    return obj


def overwrite_pointcloud(pointcloud, splats: SplatSet, unchanged=frozenset()) -> None:
    """Replace a PointCloud's splats in place (Blender 5.3+, whose PointCloud has `resize`):
    the datablock, its users and its type stay; Blender re-evaluates it. `unchanged`: as
    write_attributes, plus "positions"; ignored when the point count changes."""
    if len(pointcloud.points) != splats.count:
        pointcloud.resize(splats.count)
        unchanged = frozenset()
    if splats.count:
        if "positions" not in unchanged:
            _set(pointcloud.attributes, "position", "FLOAT_VECTOR", splats.positions)
        write_attributes(pointcloud.attributes, splats, unchanged)
    pointcloud.update_tag()


def _fill(pointcloud, splats: SplatSet) -> None:
    if ".select_vert" in pointcloud.attributes:
        pointcloud.attributes.remove(pointcloud.attributes[".select_vert"])
    if splats.count:
        write_attributes(pointcloud.attributes, splats)
    else:  # an empty PointCloud still declares the schema, so it counts as splat data
        for attr_name, data_type in schema(splats.sh_degree)[1:]:
            pointcloud.attributes.new(attr_name, data_type, "POINT")


def _relink(obj, collection) -> None:
    master = bpy.context.scene.collection
    if collection is not None and collection != master:
        collection.objects.link(obj)
        master.objects.unlink(obj)


def _convert_to_pointcloud(helper) -> bpy.types.PointCloud:
    # The convert operator works on a selected object linked into the view layer, in
    # object mode; the object then holds the PointCloud (new_pointcloud drops the object).
    bpy.context.scene.collection.objects.link(helper)
    with bpy.context.temp_override(active_object=helper, object=helper, selected_objects=[helper],
                                   selected_editable_objects=[helper]):
        bpy.ops.object.convert(target="POINTCLOUD", keep_original=False)
    if not isinstance(helper.data, bpy.types.PointCloud):
        raise RuntimeError("Blender did not convert the helper mesh to a PointCloud")
    return helper.data


def sh_count_in(attributes) -> int:
    """Number of complete-degree radiance:sh_k attributes Splatline reads (0, 3, 8 or 15):
    a degree-4 PointCloud's sh_15..23 are beyond what it renders (dropped_sh_names)."""
    k = 0
    while sh_name(k) in attributes:
        k += 1
    return _largest_complete(k)


def dropped_sh_names(attributes) -> list[str]:
    """radiance:sh_k attributes Splatline does not render: those past the last complete
    band up to degree 3, e.g. sh_15..sh_23 of a degree-4 PointCloud from Blender 5.3."""
    k = sh_count_in(attributes)
    names = []
    while sh_name(k) in attributes:
        names.append(sh_name(k))
        k += 1
    return names


_WARNED: set[tuple] = set()


def _warn_dropped(pointcloud, attributes) -> None:
    """Log once per PointCloud and attribute set what the read leaves out (it is kept on
    the PointCloud: Blender's own drawing may use it)."""
    dropped = dropped_sh_names(attributes)
    key = (getattr(pointcloud.original, "name_full", ""), tuple(dropped))
    if dropped and key not in _WARNED:
        _WARNED.add(key)
        log.warning("PointCloud %r: %s..%s not rendered (Splatline renders SH up to degree 3)",
                    key[0], dropped[0], dropped[-1])


def splats_from_pointcloud(pointcloud, axes: str = AXES_RDF) -> SplatSet:
    """Read the splat attributes of a (possibly evaluated) PointCloud into a SplatSet.
    SH bands Splatline does not render (degree 4) are left out and logged."""
    attributes = pointcloud.attributes
    n = len(pointcloud.points)
    degree = sh_degree_for(sh_count_in(attributes))
    _warn_dropped(pointcloud, attributes)
    if n == 0:  # an empty PointCloud has no position attribute at all
        return SplatSet.allocate(0, degree, axes)
    base = _get(attributes, BASE, 4, n)
    planes = np.empty((sh_coeff_count(degree), n, 3), np.float32)
    for i in range(planes.shape[0]):
        stop.check()  # a render's stop: 15 planes of 10M splats take seconds
        attributes[sh_name(i)].data.foreach_get("vector", planes[i].reshape(-1))
    rest = swap01(planes)  # consumers (GPU uploads, effects) expect a contiguous (N, K, 3)
    return SplatSet(
        positions=_get(attributes, "position", 3, n),
        scales=_get(attributes, "scale", 3, n),
        # Blender 5.3's PLY importer stores rot_0..3 as the file has them; SplatSet holds
        # unit quaternions (effects compose and slerp them). Unit rows are left bit for bit.
        rotations=normalize_quats_(_get(attributes, "rotation", 4, n)),
        opacities=np.ascontiguousarray(base[:, 3]),
        sh_dc=np.ascontiguousarray(base[:, :3]),
        sh_rest=rest,
        axes=axes,
    )


def _largest_complete(k: int) -> int:
    """Largest full-degree coefficient count <= k (a partial band is ignored)."""
    return max(c for c in (0, 3, 8, 15) if c <= k)


def read_positions(pointcloud) -> np.ndarray:
    """(N, 3) float32 object-space centres alone (cheap next to a full SplatSet read)."""
    n = len(pointcloud.points)
    if n == 0:
        return np.zeros((0, 3), np.float32)
    return _get(pointcloud.attributes, "position", 3, n)


def read_opacities_scales_rotations(pointcloud) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(N,) opacities, (N, 3) scales and (N, 4) rotations as stored (what framing needs to
    tell which splats show and which way they face: no colours, no SH)."""
    n = len(pointcloud.points)
    attributes = pointcloud.attributes
    if n == 0:
        return np.zeros(0, np.float32), np.zeros((0, 3), np.float32), np.zeros((0, 4), np.float32)
    return (np.ascontiguousarray(_get(attributes, BASE, 4, n)[:, 3]), _get(attributes, "scale", 3, n),
            _get(attributes, "rotation", 4, n))
