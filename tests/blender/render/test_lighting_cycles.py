"""Look > Lighting against Cycles (issue 43): a floor of flat white splats at Lighting 1 in
Splatline's engine, and a mesh floor with a white Diffuse BSDF in Cycles, under the same
light, World and camera, differ by at most 10% in mean brightness, for each light type.
Real bpy, real renders read back from EXR (scene-linear)."""
from __future__ import annotations

import numpy as np
import pytest

from testing.engine_scene import add_splats, read_exr_parts, set_output, setup_render
from testing.lit_scene import LIGHTS, add_light, add_mesh_floor, grey_world, top_camera, white_floor

W = H = 24


def _combined(bpy, scene, path):
    set_output(scene, "EXR", path)
    bpy.ops.render.render(write_still=True)
    return read_exr_parts(path.with_suffix(".exr"))["ViewLayer.Combined"]


@pytest.mark.parametrize("kind", sorted(LIGHTS))
def test_lit_splat_floor_matches_cycles_mesh_floor(bpy_empty, tmp_path, kind):
    bpy = bpy_empty
    splats = add_splats(bpy, "Floor", white_floor())
    splats.splatline.look.lighting = 1.0
    mesh = add_mesh_floor(bpy)
    add_light(bpy, kind)
    top_camera(bpy)
    scene = setup_render(bpy, W, H, transparent=False)
    grey_world(bpy, scene)
    scene.splatline.render.meshes = "IGNORE"
    mesh.hide_render = True
    ours = _combined(bpy, scene, tmp_path / "splatline")[..., :3]

    mesh.hide_render, splats.hide_render = False, True
    scene.render.engine = "CYCLES"
    scene.cycles.device, scene.cycles.samples, scene.cycles.use_denoising = "CPU", 64, False
    cycles = _combined(bpy, scene, tmp_path / "cycles")[..., :3]

    mean_ours, mean_cycles = float(ours.mean()), float(cycles.mean())
    print(f"{kind}: Splatline {mean_ours:.4f}, Cycles {mean_cycles:.4f}, "
          f"ratio {mean_ours / mean_cycles:.3f}")
    assert mean_cycles > 0.06  # the light shows, above the World's 0.05
    assert abs(mean_ours / mean_cycles - 1.0) <= 0.10
    # and where: the brightness falls off across the frame alike (not just on average)
    rows_ours, rows_cycles = ours.mean(axis=(1, 2)), cycles.mean(axis=(1, 2))
    assert np.corrcoef(rows_ours, rows_cycles)[0, 1] > 0.9 or kind == "SUN"


def test_lighting_zero_renders_bit_identical_frames(bpy_empty, tmp_path):
    """Lights in the scene change nothing at Lighting 0: the frame is today's, bit for bit."""
    bpy = bpy_empty
    floor = add_splats(bpy, "Floor", white_floor(spacing=0.08))
    top_camera(bpy)
    scene = setup_render(bpy, W, H, transparent=True)
    plain = _combined(bpy, scene, tmp_path / "plain")
    add_light(bpy, "SPOT")
    grey_world(bpy, scene)
    scene.render.film_transparent = True
    assert floor.splatline.look.lighting == 0.0
    with_lights = _combined(bpy, scene, tmp_path / "lights")
    np.testing.assert_array_equal(with_lights, plain)
    floor.splatline.look.lighting = 1.0
    lit = _combined(bpy, scene, tmp_path / "lit")
    assert not np.array_equal(lit, plain)
