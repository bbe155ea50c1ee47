"""Blender 5.3 readiness: native splat PointClouds are Splatline objects, drawn once, and
degree-4 data is read to degree 3 with what was dropped reported (addon/blender/native.py)."""
from __future__ import annotations

import logging
from types import SimpleNamespace

import numpy as np

from testing.native_scene import native_object
from testing.viewport_scene import blob, camera_for


def _items(bpy):
    from addon.blender.evaluate.items import collect_items

    bpy.context.view_layer.update()
    return {item.key[0]: item for item in collect_items(bpy.context.evaluated_depsgraph_get())}


def _band4(n, seed=3):
    return np.random.default_rng(seed).normal(0.0, 0.2, (n, 9, 3)).astype(np.float32)


def test_native_pointcloud_reads_and_renders_like_a_splatline_import(bpy_empty):
    from addon.blender.data.sources import is_splat_object
    from addon.blender.data.pointcloud import new_pointcloud_object
    from addon.core import reference

    bpy = bpy_empty
    splats = blob(60, 3, seed=11, centre=(0, 0, 0), spread=0.2)
    native = native_object(bpy, "native", splats, band4=_band4(60))
    assert native.data.attributes["radiance:base"].data_type == "FLOAT4"
    assert is_splat_object(native)
    new_pointcloud_object("imported", splats)
    items = _items(bpy)
    assert set(items) == {"native", "imported"}
    got, want = items["native"].splats, items["imported"].splats
    assert got.sh_degree == 3  # band 4 is not rendered
    for field in ("positions", "scales", "opacities", "sh_dc", "sh_rest"):
        np.testing.assert_array_equal(getattr(got, field), getattr(want, field), err_msg=field)
    raw = np.empty(60 * 4, np.float32)
    native.data.attributes["rotation"].data.foreach_get("value", raw)
    np.testing.assert_allclose(raw.reshape(-1, 4), 2.0 * want.rotations, rtol=1e-6)  # as stored
    np.testing.assert_allclose(got.rotations, want.rotations, rtol=1e-6, atol=1e-7)  # unit
    camera = camera_for((0, 0, 0))
    a = reference.render([items["native"]], camera).rgba
    b = reference.render([items["imported"]], camera).rgba
    assert b[..., 3].max() > 0.5  # the splats are in view
    np.testing.assert_allclose(a, b, atol=1e-5)  # unnormalized quaternions render the same


def test_degree4_pointcloud_keeps_its_data_and_logs_what_is_not_rendered(bpy_empty, caplog):
    from addon.blender.data.pointcloud import dropped_sh_names, splats_from_pointcloud

    bpy = bpy_empty
    splats = blob(20, 3, seed=5, centre=(0, 0, 0), spread=0.2)
    obj = native_object(bpy, "deg4", splats, band4=_band4(20))
    assert dropped_sh_names(obj.data.attributes) == [f"radiance:sh_{k}" for k in range(15, 24)]
    with caplog.at_level(logging.WARNING, logger="splatline"):
        read = splats_from_pointcloud(obj.data)
        splats_from_pointcloud(obj.data)  # once per PointCloud, not per read
    np.testing.assert_array_equal(read.sh_rest, splats.sh_rest)
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and "radiance:sh_15..radiance:sh_23" in warnings[0]
    assert "radiance:sh_23" in obj.data.attributes  # reading never removes Blender's data


def test_native_pointcloud_animates_through_look_keyframes(bpy_empty):
    bpy = bpy_empty
    obj = native_object(bpy, "native", blob(30, 1, seed=2, centre=(0, 0, 0), spread=0.2))
    look = obj.splatline.look
    for frame, opacity in ((1, 0.0), (11, 1.0)):
        look.opacity = opacity
        look.keyframe_insert("opacity", frame=frame)
    scene = bpy.context.scene
    seen = []
    for frame in (1, 6, 11):
        scene.frame_set(frame)
        seen.append(_items(bpy)["native"].opacity_scale)
    np.testing.assert_allclose(seen, [0.0, 0.5, 1.0], atol=0.02)


def test_native_pointcloud_renders_through_the_splatline_engine(bpy_empty, tmp_path):
    from addon.blender.data.pointcloud import new_pointcloud_object
    from testing.engine_scene import add_camera, flat_splats, read_image, set_output, setup_render

    bpy = bpy_empty
    splats = flat_splats([(-0.8, 0.0, 0.0), (0.8, 0.0, 0.3)], [(0.2, 0.6, 0.9), (0.9, 0.4, 0.1)],
                         scale=0.4)
    native = native_object(bpy, "native", splats, rotation_scale=3.0)
    add_camera(bpy, location=(0.0, -6.0, 0.0))
    scene = setup_render(bpy, 48, 32)
    images = []
    for shown in ("native", "imported"):
        if shown == "imported":
            native.hide_render = True
            new_pointcloud_object("imported", splats)
        set_output(scene, "PNG", tmp_path / shown)
        bpy.ops.render.render(write_still=True)
        images.append(read_image(tmp_path / f"{shown}.png").astype(np.int16))
    assert images[0][..., 3].max() >= 240 and (images[0][..., 3] == 0).any()
    assert np.abs(images[0] - images[1]).max() <= 1  # the same frame as Splatline's import


def _rna_splat_item(bpy):
    """The splat item of PointCloud.type, read here straight from RNA (independently of
    native.py): 'GAUSSIAN_SPLAT' on Blender 5.3, None before it."""
    prop = bpy.types.PointCloud.bl_rna.properties.get("type")
    if prop is None or prop.type != "ENUM":
        return None
    return "GAUSSIAN_SPLAT" if "GAUSSIAN_SPLAT" in prop.enum_items else None


def test_blender_draws_natively_only_a_pointcloud_set_to_its_splat_type(bpy_empty):
    from addon.blender.data import native

    bpy = bpy_empty
    item = _rna_splat_item(bpy)
    assert native.splat_type() == item
    pointcloud = bpy.data.pointclouds.new("plain")
    assert not native.drawn_natively(pointcloud)  # a new PointCloud is plain points
    assert not native.drawn_natively(bpy.data.meshes.new("mesh"))
    assert native.mark_as_splats(pointcloud) == (item is not None)
    assert native.drawn_natively(pointcloud) == (item is not None)
    if item is not None:
        assert pointcloud.type == item
        pointcloud.type = "POINTS"
        assert not native.drawn_natively(pointcloud)


def test_splatline_imports_are_native_splats_where_blender_has_them(bpy_empty, testdata):
    from addon.blender.data import native

    bpy = bpy_empty
    assert bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "test64.ply")) == {"FINISHED"}
    data = bpy.context.active_object.data
    item = _rna_splat_item(bpy)
    assert getattr(data, "type", None) == (item or getattr(data, "type", None))
    assert native.drawn_natively(data) == (item is not None)


def test_viewport_overlay_draws_what_blender_does_not(bpy_empty):
    from addon.blender.data import native
    from addon.blender.data.pointcloud import new_pointcloud_object
    from addon.blender.viewport.scene_items import SceneItems

    bpy = bpy_empty
    ours = new_pointcloud_object("ours", blob(10, 0, seed=1, centre=(0, 0, 0), spread=0.2))
    plain = new_pointcloud_object("plain", blob(10, 0, seed=2, centre=(1, 0, 0), spread=0.2))
    if native.has_native_splats():
        plain.data.type = "POINTS"  # the user switched it back: Blender draws dots only
    cache = SceneItems()
    bpy.context.view_layer.update()
    cache.collect(bpy.context)
    want = ["plain"] if native.has_native_splats() else ["ours", "plain"]
    assert sorted(cache.items) == want
    assert native.drawn_natively(ours.data) == native.has_native_splats()


def test_file_handler_is_one_named_choice_beside_blenders_own(bpy_empty):
    from addon.blender.data import native
    from addon.blender.ops.io import IO_FH_splatline_gaussians as handler

    bpy = bpy_empty
    assert set(handler.bl_file_extensions.split(";")) == {".ply", ".splat", ".spz", ".sog", ".ksplat", ".lcc", ".lcc2"}
    assert "Splatline" in handler.bl_label  # Blender's drop menu tells the handlers apart
    assert native.native_importer(".ply") == "ply_import"  # Blender's own, every version
    assert native.native_importer(".splat") is None
    assert native.native_importer(".spz") == ("spz_import" if "spz_import" in dir(bpy.ops.wm)
                                              else None)
    labels = [cls.bl_label for cls in bpy.types.FileHandler.__subclasses__()]
    assert labels.count(handler.bl_label) == 1


def test_import_operator_warns_about_a_degree4_file(bpy_empty, tmp_path, capfd):
    from testing.degree4 import degree4_splats as _degree4, write_ply4 as _write_ply4

    bpy = bpy_empty
    s, band4 = _degree4(4)
    _write_ply4(tmp_path / "deg4.ply", s, band4)
    assert bpy.ops.import_scene.splatline_gaussians(filepath=str(tmp_path / "deg4.ply")) == {"FINISHED"}
    obj = bpy.context.active_object
    assert sorted(a.name for a in obj.data.attributes if a.name.startswith("radiance:sh_")) == \
        sorted(f"radiance:sh_{k}" for k in range(15))
    out = capfd.readouterr()
    assert "SH degree 4 in the file" in out.out + out.err  # Blender prints operator warnings
