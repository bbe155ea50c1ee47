"""Blender 5.3's own splats, made by Blender's own importers (wm.ply_import, wm.spz_import),
are Splatline objects: drawn once, rendered by Splatline's engine like its own imports.
Skipped where Blender has no native splats (4.5 .. 5.2): there is nothing to test."""
from __future__ import annotations

import numpy as np
import pytest

pytestmark = pytest.mark.usefixtures("bpy_empty")


def _blender_import(bpy, path):
    op = "ply_import" if path.suffix == ".ply" else "spz_import"
    assert getattr(bpy.ops.wm, op)(filepath=str(path)) == {"FINISHED"}
    obj = bpy.context.view_layer.objects.active
    assert obj.type == "POINTCLOUD" and obj.data.type == "GAUSSIAN_SPLAT"
    return obj


def test_blenders_ply_import_is_a_splat_object_the_overlay_leaves_alone(native_bpy, testdata):
    from addon.blender.data import native
    from addon.blender.data.sources import is_splat_object
    from addon.blender.viewport.scene_items import SceneItems

    bpy = native_bpy
    obj = _blender_import(bpy, testdata / "guitar.ply")
    assert is_splat_object(obj)
    assert native.drawn_natively(obj.data)
    assert native.drawn_natively(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data)
    cache = SceneItems()
    bpy.context.view_layer.update()
    cache.collect(bpy.context)
    assert cache.items == {}  # Blender draws it: the overlay must not draw it a second time
    obj.data.type = "POINTS"
    bpy.context.view_layer.update()
    cache.collect(bpy.context)
    assert list(cache.items) == [obj.name_full]


def test_blenders_ply_import_reads_as_splatlines_own(native_bpy, testdata):
    from addon.blender.evaluate.items import collect_items

    bpy = native_bpy
    theirs = _blender_import(bpy, testdata / "guitar.ply")
    assert bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "guitar.ply")) == {"FINISHED"}
    ours = bpy.context.view_layer.objects.active
    assert ours.data.type == "GAUSSIAN_SPLAT"
    items = {i.key[0]: i.splats for i in collect_items(bpy.context.evaluated_depsgraph_get())}
    a, b = items[theirs.name_full], items[ours.name_full]
    assert a.count == b.count == 90854 and a.sh_degree == b.sh_degree
    for field in ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), rtol=2e-6, atol=2e-7,
                                   err_msg=field)


def test_blenders_spz_import_is_a_splat_object(native_bpy, testdata):
    from addon.blender.data.pointcloud import read_positions
    from addon.blender.data.sources import is_splat_object
    from addon.core import formats

    bpy = native_bpy
    obj = _blender_import(bpy, testdata / "guitar_v3.spz")
    assert is_splat_object(obj)
    ply = formats.read(str(testdata / "guitar.ply"))
    got = read_positions(obj.data)
    assert got.shape == ply.positions.shape
    # Blender turns SPZ data itself: (x, -z, y) of the PLY's, to spz quantisation
    want = ply.positions[:, [0, 2, 1]] * np.float32([1, -1, 1])
    assert np.abs(got - want).max() < 0.01
