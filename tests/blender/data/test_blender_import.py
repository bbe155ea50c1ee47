"""Import through real bpy: the DESIGN.md attribute schema, the import options, the axis
convention on the object, multi-file import through the operator, and undo."""
from __future__ import annotations

import math

import numpy as np
import pytest

from addon.core import formats
from testing.native_scene import value_field
from addon.core.select import importance

SH_NAMES = [f"radiance:sh_{k}" for k in range(15)]


def _attr(pointcloud, name, width):
    a = pointcloud.attributes[name]
    key = value_field(a)  # FLOAT4 (5.1+) holds `vector`, FLOAT_COLOR (5.0) `color`
    out = np.empty(len(pointcloud.points) * width, np.float32)
    a.data.foreach_get(key, out)
    return out.reshape(-1, width)


def _check_schema(bpy, obj, expected, degree):
    """Names, types and domain exactly as DESIGN.md, and values equal to the core reader's
    (bit-exact: both sides are the same float32 numbers copied through foreach_set)."""
    pc = obj.data
    assert obj.type == "POINTCLOUD"
    assert len(pc.points) == expected.count
    base_type = "FLOAT4" if "FLOAT4" in bpy.types.Attribute.bl_rna.properties["data_type"].enum_items else "FLOAT_COLOR"
    want = {"position": "FLOAT_VECTOR", "scale": "FLOAT_VECTOR", "rotation": "QUATERNION",
            "radiance:base": base_type}
    want.update({name: "FLOAT_VECTOR" for name in SH_NAMES[:(degree + 1) ** 2 - 1]})
    public = {a.name: a for a in pc.attributes if not a.name.startswith(".")}
    assert {n: a.data_type for n, a in public.items()} == want
    assert {a.domain for a in public.values()} == {"POINT"}
    np.testing.assert_array_equal(_attr(pc, "position", 3), expected.positions)
    np.testing.assert_array_equal(_attr(pc, "scale", 3), expected.scales)
    np.testing.assert_array_equal(_attr(pc, "rotation", 4), expected.rotations)
    base = _attr(pc, "radiance:base", 4)
    np.testing.assert_array_equal(base[:, :3], expected.sh_dc)
    np.testing.assert_array_equal(base[:, 3], expected.opacities)
    for k in range(expected.sh_rest.shape[1]):
        np.testing.assert_array_equal(_attr(pc, SH_NAMES[k], 3), expected.sh_rest[:, k])


def test_schema_test64_degree3(bpy_empty, testdata):
    from addon.blender.data.files import import_file

    path = testdata / "test64.ply"
    obj = import_file(bpy_empty.context, path)
    expected = formats.read(path)
    assert expected.sh_degree == 3
    _check_schema(bpy_empty, obj, expected, 3)
    # f_rest is channel-major in the file: sh_k = (f_rest_k, f_rest_{k+15}, f_rest_{k+30})
    import plyfile

    raw = plyfile.PlyData.read(str(path))["vertex"]
    sh_7 = _attr(obj.data, "radiance:sh_7", 3)
    np.testing.assert_array_equal(sh_7[:, 1], np.asarray(raw["f_rest_22"], np.float32))


def test_schema_guitar_degree0(bpy_empty, testdata):
    from addon.blender.data.files import import_file

    path = testdata / "guitar.ply"
    obj = import_file(bpy_empty.context, path, max_sh_degree=0)
    _check_schema(bpy_empty, obj, formats.read(path, sh_degree=0), 0)
    assert obj.name == "guitar" and obj.data.name == "guitar"


def test_capped_degree_stores_only_needed_bands(bpy_empty, testdata):
    from addon.blender.data.files import import_file

    obj = import_file(bpy_empty.context, testdata / "test64.ply", max_sh_degree=1)
    names = [a.name for a in obj.data.attributes if a.name.startswith("radiance:sh_")]
    assert names == SH_NAMES[:3]
    full = formats.read(testdata / "test64.ply")
    np.testing.assert_array_equal(_attr(obj.data, "radiance:sh_2", 3), full.sh_rest[:, 2])


def test_prune_and_importance_limit(bpy_empty, testdata):
    from addon.blender.data.files import import_file

    path = testdata / "guitar.ply"
    full = formats.read(path)
    obj = import_file(bpy_empty.context, path, min_opacity=0.5, max_sh_degree=0)
    opacity = _attr(obj.data, "radiance:base", 4)[:, 3]
    assert len(opacity) == int((full.opacities >= 0.5).sum()) < full.count
    assert opacity.min() >= 0.5

    obj = import_file(bpy_empty.context, path, max_count=1000, max_sh_degree=0)
    assert len(obj.data.points) == 1000
    # the kept splats are the 1000 most important ones (opacity x volume), not a random draw
    score = importance(full)
    threshold = np.sort(score)[-1000]
    kept = {tuple(p) for p in _attr(obj.data, "position", 3)}
    want = {tuple(p) for p in full.positions[score >= threshold]}
    assert kept == want


def test_axis_convention_on_object(bpy_empty, testdata):
    from mathutils import Vector

    from addon.blender.data.files import import_file

    ply = import_file(bpy_empty.context, testdata / "test64.ply")
    assert tuple(ply.rotation_euler) == pytest.approx((-math.pi / 2, 0, 0), abs=1e-6)
    assert ply["splatline_axes"] == "RDF" and ply["splatline_source"].endswith("test64.ply")
    # file "up" is -y (y down); it must point to Blender's +z
    up = ply.matrix_basis.to_3x3() @ Vector((0, -1, 0))
    assert tuple(up) == pytest.approx((0, 0, 1), abs=1e-6)

    # .spz is y up, z back (SPZ's documented frame, as Blender 5.3's wm.spz_import reads it)
    spz = import_file(bpy_empty.context, testdata / "test64.spz")
    assert spz["splatline_axes"] == formats.read(testdata / "test64.spz").axes == "RUB"
    assert tuple(spz.rotation_euler) == pytest.approx((math.pi / 2, 0, 0), abs=1e-6)
    up = spz.matrix_basis.to_3x3() @ Vector((0, 1, 0))
    assert tuple(up) == pytest.approx((0, 0, 1), abs=1e-6)
    # a file holding the PLY's values (splat-transform 3.7's .spz): the override says so
    spz = import_file(bpy_empty.context, testdata / "test64.spz", axes="RDF")
    assert spz["splatline_axes"] == "RDF"
    assert tuple(spz.rotation_euler) == pytest.approx((-math.pi / 2, 0, 0), abs=1e-6)

    raw = import_file(bpy_empty.context, testdata / "test64.ply", axes="RFU")
    assert tuple(raw.rotation_euler) == (0, 0, 0) and raw["splatline_axes"] == "RFU"
    # the axis convention never touches the data
    np.testing.assert_array_equal(_attr(raw.data, "position", 3), _attr(ply.data, "position", 3))


def test_operator_multi_file(bpy_empty, testdata):
    bpy = bpy_empty
    result = bpy.ops.import_scene.splatline_gaussians(
        directory=str(testdata), files=[{"name": "test64.ply"}, {"name": "guitar.splat"}, {"name": "test64.spz"}],
        max_sh_degree=2, min_opacity=0.01)
    assert result == {"FINISHED"}
    names = sorted(o.name for o in bpy.data.objects)
    assert names == ["guitar", "test64", "test64.001"]
    assert all(o.select_get() for o in bpy.data.objects)
    assert bpy.context.view_layer.objects.active.name == "test64.001"
    test64 = bpy.data.objects["test64"]
    assert [a.name for a in test64.data.attributes if a.name.startswith("radiance:sh_")] == SH_NAMES[:8]
    assert _attr(test64.data, "radiance:base", 4)[:, 3].min() >= 0.01


def test_operator_filepath_and_menus(bpy_empty, testdata):
    bpy = bpy_empty
    assert bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "test64.ply"), max_count=10) == {"FINISHED"}
    assert len(bpy.data.objects["test64"].data.points) == 10
    handler = bpy.types.FileHandler.bl_rna_get_subclass_py("IO_FH_splatline_gaussians")
    assert handler.bl_import_operator == "import_scene.splatline_gaussians"
    assert set(handler.bl_file_extensions.split(";")) == {".ply", ".splat", ".spz", ".sog", ".ksplat", ".lcc", ".lcc2"}
    draw_funcs = [f.__name__ for f in bpy.types.TOPBAR_MT_file_import._dyn_ui_initialize()]
    assert "_menu_import" in draw_funcs
    assert "_menu_export" in [f.__name__ for f in bpy.types.TOPBAR_MT_file_export._dyn_ui_initialize()]


def test_undo_removes_import(bpy_empty, testdata):
    """Undo needs a window in context and an initialised undo stack: in background mode
    Blender starts with undo off until ed.undo_push is called."""
    bpy = bpy_empty
    window = bpy.context.window_manager.windows[0]
    with bpy.context.temp_override(window=window, screen=window.screen):
        bpy.ops.ed.undo_push(message="before import")
        # 'EXEC_DEFAULT', True: operators called from Python push undo only when asked
        bpy.ops.import_scene.splatline_gaussians("EXEC_DEFAULT", True, filepath=str(testdata / "test64.ply"))
        assert len(bpy.data.objects) == 1 and len(bpy.data.pointclouds) == 1
        bpy.ops.ed.undo()
        assert (len(bpy.data.objects), len(bpy.data.pointclouds), len(bpy.data.meshes)) == (0, 0, 0)
        bpy.ops.ed.redo()
    assert [o.name for o in bpy.data.objects] == ["test64"]
    assert len(bpy.data.objects["test64"].data.points) == 64


def test_progress_and_report(bpy_empty, testdata):
    from addon.blender.data.files import import_file_with_report

    seen = []
    obj, report = import_file_with_report(bpy_empty.context, testdata / "test64.ply", progress=seen.append)
    assert seen == [0.6, 1.0]
    assert report.count_in_file == 64 and report.sh_degree_in_file == 3
    assert len(obj.data.points) == 64


@pytest.mark.parametrize("name", ["guitar.compressed.ply", "guitar.splat", "guitar.spz", "test64.compressed.ply"])
def test_every_format_imports_with_the_schema(bpy_empty, testdata, name):
    from addon.blender.data.files import import_file

    obj = import_file(bpy_empty.context, testdata / name)
    expected = formats.read(testdata / name)
    _check_schema(bpy_empty, obj, expected, expected.sh_degree)


def test_import_from_edit_mode(bpy_empty, testdata):
    """Dropping a file while editing a mesh: the importer leaves edit mode and imports."""
    bpy = bpy_empty
    bpy.ops.mesh.primitive_cube_add()
    bpy.ops.object.mode_set(mode="EDIT")
    assert bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "test64.ply")) == {"FINISHED"}
    assert bpy.context.mode == "OBJECT"
    assert bpy.context.view_layer.objects.active.name == "test64"
    assert (len(bpy.data.objects), len(bpy.data.meshes), len(bpy.data.pointclouds)) == (2, 1, 1)


@pytest.mark.parametrize("shape", [(5, 3, 3), (3, 7, 3), (0, 4, 3), (4, 0, 3), (3000, 15, 3), (8, 5000, 3)])
def test_swap01_matches_transpose(bpy_empty, shape):
    from addon.blender.data.pointcloud import per_coefficient, swap01

    a = np.random.default_rng(0).random(shape, dtype=np.float32)
    out = swap01(a)
    assert out.flags.c_contiguous and np.array_equal(out, a.transpose(1, 0, 2))
    planes = per_coefficient(a)  # a contiguous (N, K, 3): copied into planes
    assert planes.flags.c_contiguous and np.array_equal(planes, a.transpose(1, 0, 2))
    view = out.transpose(1, 0, 2)  # already planes: no copy
    assert out.size == 0 or np.shares_memory(per_coefficient(view), out)
