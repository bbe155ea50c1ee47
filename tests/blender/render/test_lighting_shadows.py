"""Shadows on lit splats (issue 43), on real bpy: a cube made by Blender's operator between a
sun and a floor of splats darkens exactly the floor's splats inside the cube's shadow (checked
by an independent float64 ray cast against the cube's box), and the GL renderer draws the lit,
shadowed floor as the float64 reference renderer does (PSNR >= 60 dB)."""
from __future__ import annotations

import numpy as np

from addon.core.colorspace import linear_to_srgb
from addon.core.sh import C0
from testing.engine_scene import add_splats, read_exr_parts, set_output, setup_render
from testing.gl_scenes import psnr
from testing.lit_scene import add_light, grey_world, top_camera, white_floor

CUBE_CENTRE, CUBE_HALF = np.array([0.1, -0.05, 0.5]), 0.2
SUN_TILT = (0.35, -0.25, 0.0)   # Euler XYZ of the sun: it shines slanted


def _scene(bpy, spacing=0.04):
    floor = add_splats(bpy, "Floor", white_floor(spacing=spacing, size=1.6))
    floor.rotation_euler = (0.0, 0.0, 0.3)    # the floor's own turn: normals go through it
    floor.splatline.look.lighting = 1.0
    bpy.ops.mesh.primitive_cube_add(size=2 * CUBE_HALF, location=tuple(CUBE_CENTRE))
    sun = add_light(bpy, "SUN", location=(0.0, 0.0, 3.0), rotation=SUN_TILT)
    top_camera(bpy, scale=1.8)
    scene = setup_render(bpy, 40, 40, transparent=False)
    grey_world(bpy, scene)
    scene.splatline.render.meshes = "IGNORE"   # the cube casts; the frame shows only splats
    bpy.context.view_layer.update()
    return floor, sun, scene


def _in_box_shadow(points, towards_sun):
    """Slab test in float64: whether the ray from each point towards the sun meets the box."""
    lo, hi = CUBE_CENTRE - CUBE_HALF, CUBE_CENTRE + CUBE_HALF
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (lo - points) / towards_sun
        t2 = (hi - points) / towards_sun
    near = np.nanmax(np.minimum(t1, t2), axis=1)
    far = np.nanmin(np.maximum(t1, t2), axis=1)
    return (far >= near) & (far > 0)


def test_a_cube_shadows_exactly_the_floor_splats_behind_it_from_the_sun(bpy_empty):
    from addon.blender.evaluate.items import collect_items

    bpy = bpy_empty
    floor, sun, _ = _scene(bpy)
    item = next(i for i in collect_items(bpy.context.evaluated_depsgraph_get()) if i.key[0] == floor.name_full)
    points = item.splats.positions.astype(np.float64) @ item.world[:3, :3].T + item.world[:3, 3]
    towards_sun = np.array(sun.matrix_world)[:3, 2]   # the sun shines along its -Z
    shadowed = _in_box_shadow(points, towards_sun / np.linalg.norm(towards_sun))
    colour = 0.5 + C0 * item.splats.sh_dc.astype(np.float64)
    lit_value = colour[~shadowed, 0].max()
    dark = colour[:, 0] < 0.5 * lit_value
    assert 20 < shadowed.sum() < len(points) - 20
    np.testing.assert_array_equal(dark, shadowed)
    # in the shadow only the World's 0.05 lights them: the floor's albedo 1 x 0.05, in sRGB
    np.testing.assert_allclose(colour[shadowed, 0], linear_to_srgb(0.05), rtol=1e-5)


def test_gl_renderer_matches_the_reference_at_lighting_one_with_a_shadow(bpy_empty, tmp_path):
    bpy = bpy_empty
    _, _, scene = _scene(bpy, spacing=0.05)
    frames = {}
    for renderer in ("OFFSCREEN", "REFERENCE"):
        scene.splatline.render.renderer = renderer
        set_output(scene, "EXR", tmp_path / renderer)
        bpy.ops.render.render(write_still=True)
        frames[renderer] = read_exr_parts((tmp_path / renderer).with_suffix(".exr"))["ViewLayer.Combined"]
    gl, ref = frames["OFFSCREEN"], frames["REFERENCE"]
    value = psnr(np.clip(gl, 0, 1), np.clip(ref, 0, 1))
    print(f"lit, shadowed floor: GL against the float64 reference {value:.1f} dB")
    assert value >= 60.0
    assert ref[..., 0].min() < 0.1 < ref[..., 0].max()  # the shadow is in the frame


def test_a_flattened_floor_and_a_flattened_light_render(bpy_empty, tmp_path):
    """A grow keyed from scale 0 starts on a flattened object: lit, its normals are its
    plane's (the world matrix has no inverse), and a light scaled to 0 along its axis has no
    direction and lights nothing; the frame renders, finite, as the reference does."""
    bpy = bpy_empty
    floor, sun, scene = _scene(bpy, spacing=0.05)
    floor.scale = (1.0, 1.0, 0.0)   # flat along its normal: the splats' own thin axis
    spot = add_light(bpy, "SPOT", location=(0.0, -1.0, 1.0))
    spot.scale = (1.0, 1.0, 0.0)
    frames = {}
    for renderer in ("OFFSCREEN", "REFERENCE"):
        scene.splatline.render.renderer = renderer
        set_output(scene, "EXR", tmp_path / renderer)
        assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
        frames[renderer] = read_exr_parts((tmp_path / renderer).with_suffix(".exr"))["ViewLayer.Combined"]
    assert np.isfinite(frames["REFERENCE"]).all() and np.isfinite(frames["OFFSCREEN"]).all()
    assert frames["REFERENCE"][..., 0].max() > 0.3  # lit by the sun: its normals are +-z
    assert psnr(np.clip(frames["OFFSCREEN"], 0, 1), np.clip(frames["REFERENCE"], 0, 1)) >= 60.0


def test_keyed_lights_animate_and_each_frame_is_its_own(bpy_empty, tmp_path):
    """A sun keyed to turn and brighten over frames 1-3, the cube's shadow moving with it: the
    frames differ, and frame 2 rendered first, then again after frames 1 and 3 (the lit
    results of other frames kept meanwhile), is bit for bit the same frame."""
    from addon.blender.evaluate import lighting

    bpy = bpy_empty
    _, sun, scene = _scene(bpy, spacing=0.05)
    for frame, tilt, strength in ((1, 0.35, 2.0), (3, -0.35, 4.0)):
        sun.rotation_euler.x, sun.data.energy = tilt, strength
        sun.keyframe_insert("rotation_euler", frame=frame)
        sun.data.keyframe_insert("energy", frame=frame)

    def frame(n):
        scene.frame_set(n)
        set_output(scene, "EXR", tmp_path / f"f{n}")
        bpy.ops.render.render(write_still=True)
        return read_exr_parts((tmp_path / f"f{n}").with_suffix(".exr"))["ViewLayer.Combined"]

    lighting.clear()
    first = frame(2)
    one, three, again = frame(1), frame(3), frame(2)
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(one, first) and not np.array_equal(first, three)
    assert three[..., 0].mean() > one[..., 0].mean()  # the sun brightens
