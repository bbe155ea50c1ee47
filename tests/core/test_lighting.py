"""core/lighting: normals, Cycles-unit shading as an exact SH colour factor, and shadows with
their fast paths pinned to the readable references."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.lighting import shadows
from addon.core.lighting.lights import Light
from addon.core.lighting.normals import shortest_axes, splat_normals
from addon.core.lighting.shade import Lighting, irradiance, lit_splats, spot_mask, with_colour_factor
from addon.core.quaternion import from_matrix, to_matrix
from addon.core.sh import C0, sh_to_rgb
from testing.synth import random_splats


def test_shortest_axis_is_the_rotation_column_of_the_smallest_scale():
    s = random_splats(500, degree=0, seed=1)
    r, _ = to_matrix(s.rotations)
    want = r[np.arange(500), :, np.argmin(s.scales, axis=1)]
    np.testing.assert_allclose(shortest_axes(s.rotations, s.scales), want, atol=1e-12)


def test_normals_face_the_eye_and_follow_the_world_matrix():
    s = random_splats(200, degree=0, seed=2)
    world = np.diag([2.0, 1.0, 0.5, 1.0])
    world[:3, 3] = (1, 2, 3)
    eye = np.array([10.0, -4.0, 7.0])
    points, normals = splat_normals(s, world, eye)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-12)
    assert (np.einsum("ij,ij->i", normals, eye - points) >= 0).all()


def test_world_normals_are_the_inverse_transposes_and_defined_for_a_flattened_object():
    """Pinned to the inverse transpose for invertible matrices (a mirror among them); an
    object scaled to 0 along an axis (a keyed grow's first frame) has its plane's normal,
    one shrunk to a line or a point none, and is lit (by the World alone) without error."""
    from addon.core.lighting.normals import world_normals

    rng = np.random.default_rng(3)
    axes = shortest_axes(random_splats(300, degree=0, seed=3).rotations, rng.uniform(0.1, 1, (300, 3)))
    for _ in range(20):
        world = np.eye(4)
        world[:3, :3] = rng.normal(size=(3, 3))
        want = axes @ np.linalg.inv(world[:3, :3])
        want /= np.linalg.norm(want, axis=1, keepdims=True)
        np.testing.assert_allclose(world_normals(axes, world), want, atol=1e-9)
    turned = np.eye(4)
    turned[:3, :3] = to_matrix(np.array([[0.9, 0.3, -0.2, 0.1]]))[0][0]
    flat = turned @ np.diag([1.0, 0.0, 1.0, 1.0])
    normals = world_normals(axes, flat)
    plane = turned[:3, 1]
    tilted = np.abs(normals @ plane) > 1e-9
    np.testing.assert_allclose(np.abs(normals[tilted] @ plane), 1.0, atol=1e-12)
    for world in (flat, np.diag([0.0, 0.0, 1.0, 1.0]), np.diag([0.0, 0.0, 0.0, 1.0])):
        splats = random_splats(300, degree=1, seed=4)
        light = Light("SPOT", (0.2, 0.1, 2.0), (0.0, 0.0, -1.0), power=100.0)
        points, normals = splat_normals(splats, world, (0.0, 0.0, 5.0))
        visibility = [shadows.light_visibility(points, light, None, splats, world)]
        lit = lit_splats(splats, world, Lighting((light,), (0.1,) * 3, (0.0, 0.0, 5.0)), 1.0, visibility,
                         points, normals)
        assert np.isfinite(lit.sh_dc).all() and np.isfinite(lit.sh_rest).all()
        assert np.isfinite(visibility[0]).all() and (visibility[0] >= 0).all()
    assert not world_normals(axes, np.diag([0.0, 0.0, 1.0, 1.0])).any()


def test_colour_factor_scales_the_sh_colour_in_every_direction():
    s = random_splats(300, degree=3, seed=3)
    k = np.random.default_rng(0).uniform(0, 3, size=(300, 3))
    dirs = np.random.default_rng(1).normal(size=(300, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    before = sh_to_rgb(s.sh_dc, s.sh_rest, dirs, 3)
    out = with_colour_factor(s, k)
    after = sh_to_rgb(out.sh_dc, out.sh_rest, dirs, 3)
    np.testing.assert_allclose(after, k * before, atol=2e-5)


def test_a_negative_light_darkens_to_black_in_every_direction_and_no_further():
    """Blender allows negative light energy. Lit by more negative light than the World gives,
    a splat is black from every side: its colour factor is 0, not negative (a negative factor
    would turn the SH's lobes below 0.5 bright); a weaker one darkens it."""
    from addon.core.lighting.shade import colour_factor, radiance_factor

    s = random_splats(300, degree=3, seed=5)
    s.sh_dc[:] = np.abs(s.sh_dc)  # colours above 0.5: lit, well away from the black clamp
    world = np.eye(4)
    dirs = np.random.default_rng(2).normal(size=(300, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    before = np.maximum(sh_to_rgb(s.sh_dc, s.sh_rest, dirs, 3), 0.0)
    points, normals = splat_normals(s, world, None)
    for power, dark in ((-5000.0, True), (-20.0, False)):
        light = Light("POINT", (0.0, 0.0, 2.0), (0.0, 0.0, -1.0), power=power)
        lighting = Lighting((light,), (0.2,) * 3, None)
        radiance = radiance_factor(lighting, points, normals)
        k = colour_factor(s.sh_dc, radiance, 1.0)
        assert (k >= 0).all() and (k <= 1.0 + 1e-12).all()
        np.testing.assert_array_equal(k == 0.0, radiance <= 0.0)  # black where it is dark
        assert (radiance <= 0.0).mean() > (0.9 if dark else 0.0) and (radiance > 0.0).mean() > (0.0 if dark else 0.9)
        lit = lit_splats(s, world, lighting, 1.0)
        after = np.maximum(sh_to_rgb(lit.sh_dc, lit.sh_rest, dirs, 3), 0.0)
        assert (after <= before + 1e-5).all()
        assert (after[(radiance <= 0.0).all(axis=1)] == 0.0).all()


def _white_floor(n=4000, seed=0):
    """Flat white splats on z = 0 (DC giving colour 1), 2 m across."""
    s = random_splats(n, degree=0, seed=seed)
    rng = np.random.default_rng(seed)
    s.positions[:] = np.c_[rng.uniform(-1, 1, (n, 2)), np.zeros(n)]
    s.rotations[:] = [1, 0, 0, 0]
    s.scales[:] = [0.02, 0.02, 0.001]
    s.sh_dc[:] = 0.5 / C0
    s.opacities[:] = 1.0
    return s


@pytest.mark.parametrize("kind", ["SUN", "POINT", "SPOT", "AREA"])
def test_a_white_floor_under_each_light_is_lit_in_cycles_units(kind):
    """sRGB of the lit colour is the Cycles value: albedo 1 x E cos / pi (+ the world)."""
    s = _white_floor()
    light = Light(kind, (0.0, 0.0, 2.0), (0.0, 0.0, -1.0), color=(1.0, 0.5, 0.25), power=1000.0,
                  strength=np.pi, spot_size=np.radians(90), spot_blend=0.5)
    world = np.eye(4)
    lit = lit_splats(s, world, Lighting((light,), (0.1, 0.1, 0.1), (0.0, 0.0, 5.0)), 1.0)
    colour = 0.5 + C0 * lit.sh_dc.astype(np.float64)
    from addon.core.colorspace import srgb_to_linear
    linear = srgb_to_linear(colour)
    p = s.positions.astype(np.float64)
    d2 = ((p - [0, 0, 2]) ** 2).sum(1)
    cos = 2 / np.sqrt(d2)
    e = {"SUN": np.full(len(p), np.pi), "POINT": 1000 / (4 * np.pi * d2) * cos,
         "SPOT": 1000 / (4 * np.pi * d2) * cos * spot_mask(cos, np.radians(90), 0.5),
         "AREA": 1000 * cos * cos / (np.pi * d2)}[kind]
    want = 0.1 + e[:, None] / np.pi * [1.0, 0.5, 0.25]
    np.testing.assert_allclose(linear, want, rtol=2e-5)


def test_lighting_zero_returns_the_very_splats():
    s = random_splats(50, degree=1, seed=4)
    light = Light("SUN", (0, 0, 0), (0, 0, -1), strength=3.0)
    assert lit_splats(s, np.eye(4), Lighting((light,)), 0.0) is s


def test_a_light_behind_the_sheet_lights_nothing():
    n = np.array([[0.0, 0.0, 1.0]])
    behind = Light("POINT", (0.0, 0.0, -1.0), (0.0, 0.0, 1.0), power=100.0)
    assert irradiance(behind, np.zeros((1, 3)), n)[0] == 0.0


def _cube(centre, half):
    c = np.array(centre, np.float64)
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64) * half + c
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return np.array([[v[a], v[b], v[c_]] for a, b, c_, d in faces for (a, b, c_) in ((a, b, c_), (a, c_, d))])


@pytest.mark.parametrize("light", [
    Light("SUN", (0, 0, 0), (0.3, -0.2, -1.0)),
    Light("POINT", (0.2, 0.1, 3.0), (0, 0, -1)),
    Light("POINT", (-0.5, 0.6, 0.9), (0, 0, -1)),  # beside a cube: its triangles cross face planes
    Light("SPOT", (-0.5, 0.4, 2.0), (0.2, -0.1, -1.0)),
])
def test_mesh_shadows_fast_path_equals_the_brute_force_reference(light):
    rng = np.random.default_rng(5)
    pts = np.c_[rng.uniform(-1.5, 1.5, (3000, 2)), rng.uniform(-0.05, 0.05, 3000)]
    tris = np.concatenate([_cube((0.1, 0.0, 0.5), 0.25), _cube((-0.7, 0.6, 0.9), 0.1)])
    fast = shadows.mesh_visibility(pts, light, tris)
    ref = shadows.mesh_visibility_reference(pts, light, tris)
    np.testing.assert_array_equal(fast, ref)
    assert 0 < (fast == 0).sum() < len(pts)


def test_splat_transmittance_fast_path_equals_the_reference():
    s = random_splats(600, degree=0, seed=6)
    s.positions[:] = np.random.default_rng(6).uniform(-1, 1, (600, 3))
    for light in (Light("SUN", (0, 0, 0), (0.2, 0.1, -1.0)), Light("POINT", (0.0, 0.0, 3.0), (0, 0, -1))):
        pts = s.positions.astype(np.float64)
        fast = shadows.splat_transmittance(pts, s, np.eye(4), light, cell=0.3)
        ref = shadows.splat_transmittance_reference(pts, s, np.eye(4), light, cell=0.3)
        np.testing.assert_allclose(fast, ref, rtol=1e-9, atol=1e-12)
        assert fast.min() < 0.9 and fast.max() == 1.0


def test_a_cast_shadow_off_light_reaches_everything():
    pts = np.zeros((4, 3))
    light = Light("SUN", (0, 0, 0), (0, 0, -1), shadow=False)
    assert (shadows.light_visibility(pts, light, _cube((0, 0, 1), 0.2)) == 1).all()
