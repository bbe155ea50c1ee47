"""Object > Apply > Splat Rotation & Scale on real captures (real bpy): the frame Splatline's
engine renders is the same before and after, and the object is left with an identity
rotation and scale."""
from __future__ import annotations

import math

import numpy as np
import pytest

from testing.engine_scene import add_camera, read_exr_parts, set_output, setup_render
from testing.viewport_scene import psnr

W, H = 128, 96


def _render(bpy, path):
    scene = bpy.context.scene
    set_output(scene, "EXR", path)
    bpy.ops.render.render(write_still=True)
    return read_exr_parts(path.with_suffix(".exr"))["ViewLayer.Combined"]


def _frame_it(bpy, obj):
    from addon.blender.data.pointcloud import read_positions

    world = np.array(obj.matrix_world)
    p = read_positions(obj.data).astype(np.float64) @ world[:3, :3].T + world[:3, 3]
    lo, hi = np.percentile(p, [2, 98], axis=0)
    centre, size = (lo + hi) / 2, float(np.linalg.norm(hi - lo))
    add_camera(bpy, location=tuple(centre + (0.3 * size, -1.3 * size, 0.4 * size)), target=tuple(centre))
    setup_render(bpy, W, H)


def _apply(bpy, obj):
    for other in bpy.context.selected_objects:
        other.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    return bpy.ops.object.splatline_apply_transform()


def _round_trip(bpy, obj, tmp_path, rotation, scale, bar=100.0):
    """bar: measured 132 dB on 5.0 and 5.3 (float32 storage of the baked values); the
    renderer's own bar against the reference is 60 dB, and a missing SH turn costs ~20."""
    obj.rotation_mode = "XYZ"
    obj.rotation_euler = rotation
    obj.scale = scale
    obj.location = (0.4, -0.2, 0.3)
    bpy.context.view_layer.update()
    _frame_it(bpy, obj)
    world = np.array(obj.matrix_world)
    before = _render(bpy, tmp_path / "before")
    assert _apply(bpy, obj) == {"FINISHED"}
    bpy.context.view_layer.update()
    after = _render(bpy, tmp_path / "after")
    assert tuple(obj.rotation_euler) == (0.0, 0.0, 0.0) and tuple(obj.scale) == (1.0, 1.0, 1.0)
    np.testing.assert_allclose(np.array(obj.matrix_world)[:3, 3], world[:3, 3], atol=1e-6)
    assert before[..., 3].max() > 0.5
    assert psnr(before, after) >= bar, psnr(before, after)
    return before, after


def test_degree_3_capture_keeps_its_frame(bpy_empty, testdata, tmp_path):
    from addon.blender.data.files import import_file

    bpy = bpy_empty
    obj = import_file(bpy.context, testdata / "test64.ply")
    child = bpy.data.objects.new("child", None)
    bpy.context.scene.collection.objects.link(child)
    child.parent, child.location = obj, (0.2, 0.1, 0.0)
    from addon.blender.data.pointcloud import splats_from_pointcloud

    assert splats_from_pointcloud(obj.data).sh_degree == 3
    obj.rotation_euler, obj.scale = (-math.pi / 2 + 0.4, 0.3, 1.1), (1.6, 1.6, 1.6)
    bpy.context.view_layer.update()
    child_world = np.array(child.matrix_world)
    _round_trip(bpy, obj, tmp_path, (-math.pi / 2 + 0.4, 0.3, 1.1), (1.6, 1.6, 1.6))
    assert obj["splatline_axes"] == "RFU"
    # the location set in _round_trip moved the child too: compare without it
    np.testing.assert_allclose(np.array(child.matrix_world)[:3, :3], child_world[:3, :3], atol=1e-6)


def test_guitar_with_its_axes_and_a_non_uniform_scale(bpy_empty, testdata, tmp_path):
    """guitar.ply (degree 0) imported with its RDF axes on the transform, scaled unevenly:
    the ellipsoids become other ellipsoids (linear_map), exactly."""
    from addon.blender.data.files import import_file

    bpy = bpy_empty
    obj = import_file(bpy.context, testdata / "guitar.ply")
    axes = tuple(obj.rotation_euler)
    assert axes[0] == pytest.approx(-math.pi / 2)
    _round_trip(bpy, obj, tmp_path, axes, (1.0, 2.0, 0.7))


def test_non_uniform_scale_of_sh_colour_is_refused_and_nothing_changes(bpy_empty, testdata):
    from addon.blender.data.files import import_file
    from addon.blender.data.pointcloud import splats_from_pointcloud

    bpy = bpy_empty
    obj = import_file(bpy.context, testdata / "test64.ply")
    obj.scale = (1.0, 2.0, 1.0)
    positions = splats_from_pointcloud(obj.data).positions.copy()
    with pytest.raises(RuntimeError, match="non-uniform"):
        _apply(bpy, obj)
    assert tuple(obj.scale) == (1.0, 2.0, 1.0)
    np.testing.assert_array_equal(splats_from_pointcloud(obj.data).positions, positions)


def test_blender_53_own_import(native_bpy, testdata, tmp_path):
    bpy = native_bpy
    bpy.ops.wm.ply_import(filepath=str(testdata / "test64.ply"))
    obj = bpy.context.selected_objects[0]
    assert obj.type == "POINTCLOUD"
    _round_trip(bpy, obj, tmp_path, (0.5, -0.3, 0.8), (0.7, 0.7, 0.7))
