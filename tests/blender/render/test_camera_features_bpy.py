"""Blender camera -> core Camera for the camera features (blender/render/camera.py):
the panoramic equirectangular camera, checked against Cycles' own render of it, depth
of field from Camera.dof, and both through the engine and the command line."""
from __future__ import annotations

import math

import numpy as np
import pytest

from addon.core import reference
from testing.engine_scene import add_camera, add_splats, read_exr_parts, set_output, setup_render
from testing.gl_scenes import psnr

PANO_POINTS = [(3.0, 1.0, 0.5), (-2.0, -2.0, 1.5), (0.5, 0.1, 4.0), (1.0, 3.0, -1.0)]


def _pano_camera(bpy, location=(0.3, -0.2, 0.5), rotation=(1.2, 0.3, 0.4)):
    scene = bpy.context.scene
    data = bpy.data.cameras.new("Pano")
    data.type = "PANO"
    from addon.blender.render.camera import panorama_settings

    panorama_settings(data).panorama_type = "EQUIRECTANGULAR"
    obj = bpy.data.objects.new("Pano", data)
    scene.collection.objects.link(obj)
    obj.location, obj.rotation_euler = location, rotation
    scene.camera = obj
    return obj


def _emitter(bpy, location):
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.08, location=location)
    obj = bpy.context.object
    material = bpy.data.materials.new("glow")
    if material.node_tree is None:  # 4.5: no tree until use_nodes
        material.use_nodes = True
    nodes = material.node_tree.nodes
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 50.0
    output = next(n for n in nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    material.node_tree.links.new(emission.outputs[0], output.inputs["Surface"])
    obj.data.materials.append(material)


def test_equirect_camera_lands_where_cycles_draws(bpy_empty, tmp_path):
    """Four small emitters rendered by Cycles through a rotated equirect camera: each
    blob's centroid is where camera_from_blender projects its centre (within 1 px at
    128x64: the blobs are ~3 px wide, sampled with 4 paths per pixel)."""
    bpy = bpy_empty
    from addon.blender.compat import world_node_tree
    from addon.blender.render.camera import camera_from_blender

    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 4
    scene.render.resolution_x, scene.render.resolution_y = 128, 64
    scene.render.resolution_percentage = 100
    scene.world = bpy.data.worlds.new("dark")
    world_node_tree(scene.world).nodes["Background"].inputs["Strength"].default_value = 0.0
    camera = _pano_camera(bpy)
    for p in PANO_POINTS:
        _emitter(bpy, p)
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.filepath = str(tmp_path / "cycles.exr")
    bpy.ops.render.render(write_still=True)
    import OpenImageIO as oiio

    light = np.asarray(oiio.ImageBuf(str(tmp_path / "cycles.exr")).get_pixels(oiio.FLOAT))[..., :3].sum(-1)
    ys, xs = np.nonzero(light > 0.5)
    cam = camera_from_blender(scene, camera)
    assert cam.kind == "equirect"
    for u, v, _ in cam.project(np.array(PANO_POINTS)):
        near = (np.abs(xs + 0.5 - u) < 6) & (np.abs(ys + 0.5 - v) < 6)
        w = light[ys[near], xs[near]]
        assert w.size >= 2, f"no Cycles blob near ({u:.1f}, {v:.1f})"
        centroid = np.array([(xs[near] + 0.5) @ w, (ys[near] + 0.5) @ w]) / w.sum()
        assert np.hypot(*(centroid - (u, v))) < 1.0


def test_panorama_window_and_other_types(bpy_empty):
    bpy = bpy_empty
    from addon.blender.render.camera import camera_from_blender, panorama_settings

    setup_render(bpy, 200, 100)
    obj = _pano_camera(bpy, location=(0, 0, 0), rotation=(math.pi / 2, 0, 0))
    settings = panorama_settings(obj.data)
    settings.longitude_min, settings.longitude_max = -math.pi / 2, math.pi / 2
    settings.latitude_min, settings.latitude_max = -math.pi / 4, math.pi / 4
    bpy.context.view_layer.update()
    cam = camera_from_blender(bpy.context.scene, obj)
    # world +y is straight ahead for this rotation; world +x is 90 deg to the right
    uv = cam.project(np.array([[0.0, 5.0, 0.0], [5.0, 0.0, 0.0], [0.0, 5.0, 5.0]]))[:, :2]
    np.testing.assert_allclose(uv, [[100, 50], [200, 50], [100, 0]], atol=1e-4)  # float32 matrix
    settings.panorama_type = "FISHEYE_EQUISOLID"
    with pytest.raises(ValueError, match="FISHEYE_EQUISOLID is not supported"):
        camera_from_blender(bpy.context.scene, obj)


def test_depth_of_field_read_from_the_camera(bpy_empty):
    bpy = bpy_empty
    from addon.blender.render.camera import camera_from_blender

    setup_render(bpy, 64, 48)
    obj = add_camera(bpy, location=(0.0, -8.0, 1.0), target=(0.0, 0.0, 1.0), lens=35.0)
    scene = bpy.context.scene
    assert camera_from_blender(scene, obj).defocus is None  # use_dof off
    obj.data.dof.use_dof = True
    obj.data.dof.focus_distance = 6.5
    obj.data.dof.aperture_fstop = 1.4
    d = camera_from_blender(scene, obj).defocus
    assert d.focus_distance == pytest.approx(6.5, rel=1e-6)
    assert d.aperture_radius == pytest.approx(0.035 / (2 * 1.4), rel=1e-6)
    target = bpy.data.objects.new("focus", None)
    scene.collection.objects.link(target)
    target.location = (2.0, -3.0, 4.0)  # 5 along the view axis, off to the side
    obj.data.dof.focus_object = target
    bpy.context.view_layer.update()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    assert camera_from_blender(scene, obj, depsgraph).defocus.focus_distance == pytest.approx(5.0)
    obj.data.type = "ORTHO"
    assert camera_from_blender(scene, obj).defocus is None  # not modelled for ortho


def _cloud(bpy):
    from testing.gl_scenes import random_splats

    s = random_splats(1500, 2, seed=5, spread=1.5)
    return add_splats(bpy, "cloud", s)


@pytest.mark.parametrize("feature", ["equirect", "dof"])
def test_engine_renders_the_feature_as_the_reference(bpy_empty, tmp_path, feature):
    bpy = bpy_empty
    from addon.blender.evaluate.items import collect_items
    from addon.blender.render.camera import camera_from_blender
    from addon.core.colorspace import premultiplied_srgb_to_linear as to_scene_linear

    _cloud(bpy)
    scene = setup_render(bpy, 128, 64)
    if feature == "equirect":
        _pano_camera(bpy, location=(0.2, -0.3, 0.1), rotation=(1.4, 0.0, 0.3))
    else:
        obj = add_camera(bpy, location=(0.0, -6.0, 0.5), target=(0.0, 0.0, 0.0))
        obj.data.dof.use_dof, obj.data.dof.focus_distance, obj.data.dof.aperture_fstop = True, 4.0, 0.5
    set_output(scene, "EXR", tmp_path / "still")
    bpy.ops.render.render(write_still=True)
    got = read_exr_parts(tmp_path / "still.exr")["ViewLayer.Combined"]
    depsgraph = bpy.context.evaluated_depsgraph_get()
    camera = camera_from_blender(scene, scene.camera, depsgraph)
    assert camera.kind == "equirect" if feature == "equirect" else camera.defocus is not None
    want = to_scene_linear(reference.render(collect_items(depsgraph), camera).rgba)
    assert psnr(got, want) >= 60.0 and want[..., 3].max() > 0.5


def test_command_line_renders_a_panorama_with_dof_off_and_motion_blur(bpy_empty, tmp_path):
    """`python -m addon render` reads the same camera: an equirect .blend renders headless."""
    from testing.cli_runs import render_all as _run_all

    bpy = bpy_empty
    _cloud(bpy)
    scene = setup_render(bpy, 64, 32)
    cam = _pano_camera(bpy, location=(0.2, -0.3, 0.1), rotation=(1.4, 0.0, 0.3))
    for frame, z in ((1, 0.0), (2, 0.4)):
        cam.rotation_euler.z = z
        cam.keyframe_insert("rotation_euler", frame=frame)
    scene.render.use_motion_blur = True
    path = tmp_path / "pano.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    _run_all([(path, "--out", tmp_path / "out", "--format", "EXR", "--frames", "2",
               "--engine-option", "motion_blur_samples=3")])
    rgba = read_exr_parts(tmp_path / "out" / "frame_0002.exr")["ViewLayer.Combined"]
    assert rgba.shape == (32, 64, 4) and np.isfinite(rgba).all() and rgba[..., 3].max() > 0.5
