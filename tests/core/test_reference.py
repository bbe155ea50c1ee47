"""Analytic checks of the float64 reference renderer (core/reference.py).

Every expected value is computed here by hand from DESIGN.md's formulas, not by
calling preprocess.py. Output is float32, so values in [0, 1] are compared to
within TOL = 1e-6 (float32 spacing near 1 is 6e-8; the float64 maths is far
more accurate than that).
"""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.camera import Camera, look_at, simple_camera
from addon.core.reference import render
from addon.core.scene import RenderItem, RenderOptions
from addon.core.sh import C0, C1
from addon.core.splats import SplatSet

TOL = 1e-6


def splats(positions, scale=0.1, opacity=1.0, rgb=(0.5, 0.5, 0.5), degree=0) -> SplatSet:
    """Isotropic splats with identity rotation and DC colour rgb (before +0.5 offset removal)."""
    pos = np.atleast_2d(np.asarray(positions, np.float32))
    s = SplatSet.allocate(len(pos), degree)
    s.positions[:] = pos
    s.scales[:] = np.asarray(scale, np.float32).reshape(-1, 1) if np.ndim(scale) < 2 else scale
    s.opacities[:] = opacity
    s.sh_dc[:] = (np.asarray(rgb, np.float64) - 0.5) / C0
    return s


def axis_camera(size=33, f=40.0, ortho=False, w2c=None) -> Camera:
    """Camera at the origin looking down -z; odd size so the axis hits a pixel centre."""
    c = size / 2.0
    return Camera(np.eye(4) if w2c is None else w2c, size, size, f, f, c, c, 0.1, 100.0, ortho)


def gaussian_image(cam, u, v, var, opacity, capped=False):
    """Expected alpha of one isotropic screen Gaussian with variance var (incl. low-pass)."""
    ys, xs = np.mgrid[0:cam.height, 0:cam.width] + 0.5
    r2 = (xs - u) ** 2 + (ys - v) ** 2
    alpha = np.minimum(0.99, opacity * np.exp(-0.5 * r2 / var))
    extent = np.sqrt(2 * np.log(255 * opacity))  # the 1/255 contour
    extent = min(3.0, extent) if capped else extent
    radius = extent * np.sqrt(var + np.sqrt(0.1))  # INRIA: mid + sqrt(max(0.1, mid^2 - det))
    inside = (np.abs(xs - u) <= radius) & (np.abs(ys - v) <= radius) & (alpha >= 1 / 255)
    return np.where(inside, alpha, 0.0)


@pytest.mark.parametrize("opacity", [0.3, 0.8, 1.0])
@pytest.mark.parametrize("capped", [False, True])
def test_isotropic_splat_peak_and_falloff(opacity, capped):
    cam, d, s = axis_camera(), 2.0, 0.05
    item = RenderItem(splats([0, 0, -d], s, opacity, rgb=(0.2, 0.6, 1.0)))
    out = render([item], cam, RenderOptions(capped_extent=capped))
    var = (cam.fx * s / d) ** 2 + 0.3
    expect = gaussian_image(cam, 16.5, 16.5, var, opacity, capped)
    assert out.rgba[16, 16, 3] == pytest.approx(min(0.99, opacity), abs=TOL)
    np.testing.assert_allclose(out.rgba[..., 3], expect, atol=TOL)
    np.testing.assert_allclose(out.rgba[..., :3], expect[..., None] * [0.2, 0.6, 1.0], atol=TOL)


def test_antialiased_compensation():
    cam, d, s, o = axis_camera(), 4.0, 0.01, 0.9
    item = RenderItem(splats([0, 0, -d], s, o))
    out = render([item], cam, RenderOptions(antialiased=True))
    var0 = (cam.fx * s / d) ** 2
    o_eff = o * np.sqrt(var0 ** 2 / (var0 + 0.3) ** 2)  # sqrt(det / det_lowpass)
    np.testing.assert_allclose(out.rgba[..., 3], gaussian_image(cam, 16.5, 16.5, var0 + 0.3, o_eff),
                               atol=TOL)


def _two_splats(camera_side):
    red = splats([0, 0, -2], 0.1, 0.7, rgb=(1, 0, 0))
    green = splats([0, 0, -4], 0.1, 0.6, rgb=(0, 1, 0))
    if camera_side == "front":
        w2c = np.eye(4)
    else:  # behind the green one, looking back towards +z
        w2c = look_at((0, 0, -6), (0, 0, 0), up=(0, 1, 0))
    return [RenderItem(red), RenderItem(green)], axis_camera(w2c=w2c)


@pytest.mark.parametrize("side", ["front", "back"])
@pytest.mark.parametrize("swap_items", [False, True])
def test_two_splats_composite_in_depth_order(side, swap_items):
    items, cam = _two_splats(side)
    if swap_items:
        items = items[::-1]
    out = render(items, cam, RenderOptions())
    red, green = (0.7, (1, 0, 0)), (0.6, (0, 1, 0))
    (a1, c1), (a2, c2) = (red, green) if side == "front" else (green, red)
    expect_rgb = a1 * np.array(c1) + (1 - a1) * a2 * np.array(c2)
    np.testing.assert_allclose(out.rgba[16, 16, :3], expect_rgb, atol=TOL)
    assert out.rgba[16, 16, 3] == pytest.approx(1 - (1 - a1) * (1 - a2), abs=TOL)
    # the Z pass: alpha-weighted view depth, the front splat 2 away, the back one 4
    w1, w2 = a1, (1 - a1) * a2
    assert out.depth[16, 16] == pytest.approx((2.0 * w1 + 4.0 * w2) / (w1 + w2))
    assert np.isinf(out.depth[0, 0])


def test_objects_interleave_by_depth():
    # Object A holds splats at depths 2 and 6; object B (moved by its world matrix)
    # one at depth 4, so the global order is A, B, A.
    a = RenderItem(splats([[0, 0, -2], [0, 0, -6]], 0.1, [0.45, 0.9], rgb=(1, 0, 0)))
    a.splats.sh_dc[1] = (np.array([0, 0, 1.0]) - 0.5) / C0
    world_b = np.eye(4)
    world_b[:3, 3] = (3.0, -1.0, -4.0)
    b = RenderItem(splats([-3, 1, 0], 0.1, 0.4, rgb=(0, 1, 0)), world=world_b)
    out = render([a, b], axis_camera(), RenderOptions())
    alphas, cols = [0.45, 0.4, 0.9], np.eye(3)
    t, expect = 1.0, np.zeros(3)
    for al, col in zip(alphas, cols):
        expect += t * al * col
        t *= 1 - al
    np.testing.assert_allclose(out.rgba[16, 16, :3], expect, atol=TOL)
    assert out.rgba[16, 16, 3] == pytest.approx(1 - t, abs=TOL)
    weights = np.array([0.45, 0.55 * 0.4, 0.55 * 0.6 * 0.9])  # T alpha of each
    assert out.depth[16, 16] == pytest.approx(weights @ [2.0, 4.0, 6.0] / weights.sum())


def _rot_z(deg):
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


@pytest.mark.parametrize("eye", [(0.0, -5.0, 0.0), (4.0, 1.0, 3.0), (-2.0, 3.0, -4.0)])
def test_rotated_object_sh_degree1_uses_local_view_direction(eye):
    world = np.eye(4)
    world[:3, :3] = _rot_z(90) @ np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0.0]])  # Rz(90) Rx(90)
    world[:3, 3] = (1.0, 2.0, 0.5)
    p_local = np.array([0.3, -0.2, 0.1])
    s = splats(p_local, 0.05, 0.8, rgb=(0.5, 0.5, 0.5), degree=1)
    s.sh_rest[0, 0] = (0.3, -0.2, 0.1)   # coefficient of -C1 y
    s.sh_rest[0, 1] = (-0.1, 0.25, 0.2)  # coefficient of  C1 z
    s.sh_rest[0, 2] = (0.2, 0.1, -0.3)   # coefficient of -C1 x
    centre_world = world[:3, :3] @ p_local + world[:3, 3]
    cam = axis_camera(w2c=look_at(eye, centre_world))
    # By hand: camera position into the local frame, direction camera -> centre there.
    eye_local = world[:3, :3].T @ (np.asarray(eye) - world[:3, 3])
    x, y, z = (p_local - eye_local) / np.linalg.norm(p_local - eye_local)
    rest = s.sh_rest[0].astype(np.float64)
    rgb = 0.5 - C1 * y * rest[0] + C1 * z * rest[1] - C1 * x * rest[2]
    out = render([RenderItem(s, world=world)], cam, RenderOptions())
    np.testing.assert_allclose(out.rgba[16, 16, :3], 0.8 * rgb, atol=TOL)
    # The world-frame direction would give another colour: the test can tell them apart.
    xw, yw, zw = (centre_world - eye) / np.linalg.norm(centre_world - eye)
    wrong = 0.5 - C1 * yw * rest[0] + C1 * zw * rest[1] - C1 * xw * rest[2]
    assert np.abs(0.8 * wrong - out.rgba[16, 16, :3]).max() > 1e-3


def test_orthographic_splat_and_constant_view_direction():
    f = 20.0  # pixels per world unit
    cam = axis_camera(ortho=True, f=f)
    s = splats([[0, 0, -3], [0.5, 0.25, -7]], 0.04, 0.9, degree=1)
    s.sh_rest[:, 1] = (0.4, -0.4, 0.2)  # z term only: C1 * z, and z = -1 along the forward axis
    out = render([RenderItem(s)], cam, RenderOptions())
    var = (f * 0.04) ** 2 + 0.3
    rgb = 0.5 + C1 * -1.0 * np.array([0.4, -0.4, 0.2])
    for (px, py), u, v in (((16, 16), 16.5, 16.5), ((26, 11), 16.5 + 10, 16.5 - 5)):
        expect = gaussian_image(cam, u, v, var, 0.9)
        assert out.rgba[py, px, 3] == pytest.approx(0.9, abs=TOL)
        np.testing.assert_allclose(out.rgba[py, px, :3], 0.9 * rgb, atol=TOL)
        window = (slice(py - 3, py + 4), slice(px - 3, px + 4))
        np.testing.assert_allclose(out.rgba[window][..., 3], expect[window], atol=TOL)


def test_early_termination_differs_only_below_t_stop():
    depths = [-2, -3, -4, -5, -6]
    s = splats([[0, 0, z] for z in depths], 0.3, 0.95, rgb=(1, 1, 1))
    s.sh_dc[:, 0] = (np.array([1, 0.8, 0.6, 0.4, 0.2]) - 0.5) / C0  # red tells the layers apart
    cam = axis_camera()
    full = render([RenderItem(s)], cam, RenderOptions(early_termination=False))
    stop = render([RenderItem(s)], cam, RenderOptions(early_termination=True))
    reds = [1, 0.8, 0.6, 0.4, 0.2]
    t_full, r_full = 1.0, 0.0
    for r in reds:
        r_full += t_full * 0.95 * r
        t_full *= 0.05
    # T: 0.05, 0.0025, 1.25e-4, then 6.25e-6 < 1e-4: the 4th splat is not blended.
    r_stop = sum(0.95 * r * 0.05 ** k for k, r in enumerate(reds[:3]))
    assert full.rgba[16, 16, 0] == pytest.approx(r_full, abs=TOL)
    assert stop.rgba[16, 16, 0] == pytest.approx(r_stop, abs=TOL)
    assert stop.rgba[16, 16, 3] == pytest.approx(1 - 0.05 ** 3, abs=TOL)
    differ = np.any(full.rgba != stop.rgba, axis=2)
    t_final = 1.0 - full.rgba[..., 3].astype(np.float64)
    assert differ.any()
    assert np.all(t_final[differ] < 1e-4 + TOL)
    # What termination skips is at most the transmittance before the stop, < 1e-4 / 0.01.
    assert np.abs(full.rgba - stop.rgba).max() <= 1e-2


def test_background_colour_matrix_and_degree_cap():
    s = splats([0, 0, -2], 0.05, 0.6, rgb=(0.2, 0.4, 0.6), degree=1)
    s.sh_rest[0, 1] = (1.0, 1.0, 1.0)
    cm = np.array([[2.0, 0, 0, 0.1], [0, 0.5, 0, 0], [0, 0, 1, -0.9]])
    item = RenderItem(s, color_matrix=cm, sh_degree=0, opacity_scale=0.5)
    bg = (0.1, 0.2, 0.3, 1.0)
    out = render([item], axis_camera(), RenderOptions(background=bg))
    a = 0.3
    rgb = np.maximum(np.array([0.2 * 2 + 0.1, 0.4 * 0.5, 0.6 - 0.9]), 0.0)  # blue clamps to 0
    np.testing.assert_allclose(out.rgba[16, 16], [*(a * rgb + (1 - a) * np.array(bg[:3])), 1.0],
                               atol=TOL)
    np.testing.assert_allclose(out.rgba[0, 0], bg, atol=TOL)


def test_front_to_back_equals_back_to_front_over():
    rng = np.random.default_rng(1)
    n = 40
    s = splats(rng.uniform([-0.5, -0.5, -4], [0.5, 0.5, -1], (n, 3)), 0.0, 1.0)
    s.scales[:] = rng.uniform(0.02, 0.2, (n, 3))
    q = rng.normal(size=(n, 4))
    s.rotations[:] = q / np.linalg.norm(q, axis=1, keepdims=True)
    s.opacities[:] = rng.uniform(0.05, 1, n)
    s.sh_dc[:] = rng.normal(0, 1, (n, 3))
    cam = axis_camera(size=31)
    out = render([RenderItem(s)], cam, RenderOptions())
    # Back-to-front "over" of single-splat renders, farthest first.
    singles = [render([RenderItem(s.subset([i]))], cam, RenderOptions()).rgba.astype(np.float64)
               for i in range(n)]
    acc = np.zeros((31, 31, 4))
    for i in np.argsort(s.positions[:, 2]):  # most negative z = farthest first
        a = singles[i][..., 3:4]
        acc = singles[i] + (1 - a) * acc  # singles are premultiplied: alpha c + (1-alpha) C
    # Each single is rounded to float32 before this blend: a few float32 steps.
    np.testing.assert_allclose(out.rgba, acc, atol=2e-6)


def test_window_is_the_same_pixels_of_the_full_frame():
    """window= renders part of the frame with the frame's own projection: bitwise the
    slice of the full render, across tile boundaries, splats straddling its edges."""
    rng = np.random.default_rng(5)
    n = 60
    s = SplatSet.allocate(n, 1)
    s.positions[:] = rng.uniform(-1.5, 1.5, (n, 3))
    s.scales[:] = rng.uniform(0.05, 0.4, (n, 3))
    s.rotations[:] = [1.0, 0.0, 0.0, 0.0]
    s.opacities[:] = rng.uniform(0.3, 0.9, n)
    s.sh_dc[:] = rng.normal(0.0, 1.0, (n, 3))
    s.sh_rest[:] = rng.normal(0.0, 0.2, s.sh_rest.shape)
    camera = simple_camera(300, 280, 50.0, look_at((0.0, -5.0, 0.5), (0.0, 0.0, 0.0)), near=0.1, far=100.0)
    full = render([RenderItem(s)], camera)
    x, y, w, h = 37, 250, 263, 30  # crosses the tile edge at x = 256, ends at the frame's edge
    part = render([RenderItem(s)], camera, window=(x, y, w, h))
    assert full.rgba[y:y + h, x:x + w, 3].max() > 0.2
    np.testing.assert_array_equal(part.rgba, full.rgba[y:y + h, x:x + w])
    np.testing.assert_array_equal(part.depth, full.depth[y:y + h, x:x + w])
    with pytest.raises(ValueError, match="not inside"):
        render([RenderItem(s)], camera, window=(x, y, w + 1, h))
