"""The equirectangular panoramic camera (core/equirect.py): projection, Jacobian, the
seam and the poles, in the reference and the offscreen GL renderer.

Blender's mapping itself (which way is left, where the seam is) is checked against a
Cycles render in tests/blender/render/test_camera_features_bpy.py."""
from __future__ import annotations

import math

import numpy as np
import pytest

from addon.core import equirect, reference
from addon.core.camera import equirect_camera, look_at, simple_camera
from addon.core.preprocess import project
from addon.core.scene import RenderItem, RenderOptions
from addon.core.splats import SplatSet
from addon.gl import OffscreenRenderer
from testing.gl_scenes import psnr, random_splats

W, H = 128, 64


def _splat_at(points, scale=0.15, opacity=0.9) -> RenderItem:
    points = np.asarray(points, np.float64).reshape(-1, 3)
    s = SplatSet.allocate(len(points), 0)
    s.positions[:] = points
    s.scales[:] = scale
    s.rotations[:] = (1.0, 0.0, 0.0, 0.0)
    s.opacities[:] = opacity
    s.sh_dc[:] = 1.0
    return RenderItem(s)


def _camera(w=W, h=H):
    return equirect_camera(np.eye(4), w, h)  # at the origin, looking down -z, +y up


def test_projection_by_hand():
    cam = _camera()
    uvd = cam.project(np.array([[0.0, 0.0, -2.0], [3.0, 0.0, 0.0], [-1.0, 0.0, 0.0],
                                [0.0, 1.0, -1.0], [1e-9, 0.0, 1.0]]))
    np.testing.assert_allclose(uvd[:, :2], [[64, 32], [96, 32], [32, 32], [64, 16], [128, 32]],
                               atol=1e-6)
    np.testing.assert_allclose(uvd[:, 2], [2.0, 3.0, 1.0, math.sqrt(2.0), 1.0])
    part = equirect_camera(np.eye(4), 100, 50, lon_min=0.0, lon_max=math.pi / 2,
                           lat_min=0.0, lat_max=math.pi / 4)
    u, v, _ = part.project(np.array([[1.0, math.tan(math.pi / 8) * math.sqrt(2.0), -1.0]]))[0]
    assert (u, v) == pytest.approx((50.0, 25.0))
    with pytest.raises(ValueError, match="empty"):
        equirect_camera(np.eye(4), 10, 10, lon_min=1.0, lon_max=1.0)


def test_jacobian_matches_finite_differences():
    cam = _camera(400, 200)
    t = np.random.default_rng(0).normal(size=(200, 3)) * 3.0
    lat = np.degrees(equirect.angles(t)[1])
    t = t[np.abs(lat) < 80]  # away from the pole clamp
    step = 1e-6
    numeric = np.stack([(equirect.project_points(t + d, cam) - equirect.project_points(t - d, cam))
                        / (2 * step) for d in np.eye(3) * step], axis=2)
    np.testing.assert_allclose(equirect.jacobian(t, cam), numeric, rtol=1e-6, atol=1e-6)


def test_straight_ahead_the_footprint_is_the_perspective_one():
    """At the image centre the equirect map and a pinhole with the same pixels per
    radian agree to first order: same centre, same 2D covariance."""
    item = _splat_at([[0.0, 0.0, -5.0]], scale=0.3)
    item.splats.scales[:] = (0.3, 0.1, 0.2)
    item.splats.rotations[:] = (0.9, 0.2, -0.3, 0.1)
    pano = _camera(360, 180)
    pin = simple_camera(360, 180, 90.0, np.eye(4))
    pin = type(pin)(pin.world_to_camera, 360, 180, pano.fx, pano.fy, pano.cx, pano.cy, 0.1, 100.0)
    a, b = project(item, pano), project(item, pin)
    np.testing.assert_allclose(a.means2d, b.means2d, atol=1e-9)
    np.testing.assert_allclose(a.cov2d, b.cov2d, rtol=1e-9)


@pytest.mark.parametrize("renderer", ["reference", "gl", "gl33"])
def test_splat_on_the_seam_shows_on_both_edges(renderer):
    """Straight behind the camera (longitude 180 deg): half on the left edge, half on
    the right, mirror images of each other."""
    item = _splat_at([[0.0, 0.0, 2.0]])
    out = _render(renderer, [item], _camera())
    alpha = out.rgba[..., 3]
    assert alpha[:, 0].max() > 0.5 and alpha[:, -1].max() > 0.5
    assert alpha[:, W // 4:3 * W // 4].max() == 0.0
    np.testing.assert_allclose(alpha, alpha[:, ::-1], atol=1e-5)
    # and it is the same splat as one straight ahead, cut in two
    ahead = _render(renderer, [_splat_at([[0.0, 0.0, -2.0]])], _camera()).rgba[..., 3]
    np.testing.assert_allclose(np.roll(alpha, W // 2, axis=1), ahead, atol=1e-5)


def test_splat_near_a_pole_is_finite_bounded_and_stable():
    """Climbing towards the pole along one longitude, the footprint widens as 1 / cos(lat)
    until the clamp (half a pixel row from the pole), then stays put: the quad never
    exceeds the clamp's bound, the centre keeps its longitude, nothing goes non-finite.
    At the pole itself (longitude undefined) the splat is still finite and bounded."""
    scale, dist = 0.05, 3.0
    cam = _camera()
    lats = np.radians([60.0, 80.0, 85.0, 88.0, 89.0, 89.9, 90.0 - 1e-6])
    points = dist * np.stack([np.zeros_like(lats), np.sin(lats), -np.cos(lats)], 1)
    item = _splat_at(np.vstack([points, [[0.0, dist, 0.0]]]), scale=scale)
    p = project(item, cam)
    assert p.valid.all() and np.isfinite(p.radius).all() and np.isfinite(p.conic).all()
    bound = 3.33 * math.hypot(scale * cam.fx / (dist * math.sin(equirect.pole_margin(cam.fy))),
                              scale * cam.fy / dist) + 3.33 * math.sqrt(2 * 0.3)
    assert p.radius.max() <= bound
    climbing = p.radius[:-1]
    assert np.all(np.diff(climbing) >= -1e-9) and climbing[-1] > 5 * climbing[0]
    np.testing.assert_allclose(p.means2d[:-1, 0], W / 2, atol=1e-6)  # longitude 0
    clamped = np.abs(lats) > 0.5 * math.pi - equirect.pole_margin(cam.fy)
    held = p.cov2d[:-1][clamped]
    np.testing.assert_allclose(held, np.broadcast_to(held[0], held.shape), rtol=1e-3)
    out = reference.render([_splat_at(points[-1:], scale=scale)], cam)
    assert np.isfinite(out.rgba).all() and out.rgba[0, :, 3].max() > 0.5
    assert out.rgba[H // 4:, :, 3].max() == 0.0


def _render(kind, items, camera, options=RenderOptions()):
    if kind == "reference":
        return reference.render(items, camera, options)
    with OffscreenRenderer(compute=None if kind == "gl" else False) as r:
        return r.render(items, camera, options)


@pytest.mark.parametrize("kind", ["gl", "gl33"])
@pytest.mark.parametrize("aa", [False, True])
def test_gl_matches_reference_on_an_equirect_frame(kind, aa):
    """A 2000-splat degree-2 cloud around the camera, some splats across the seam and
    near the poles. Bar 60 dB as tests/gl/test_gl_render.py; measured 93-132 dB (the
    compute path's float32 atan is the larger part)."""
    item = RenderItem(random_splats(2000, 2, seed=1, spread=3.0))
    camera = equirect_camera(look_at((0.3, 0.2, 0.1), (0.0, -1.0, 0.0)), 256, 128)
    options = RenderOptions(antialiased=aa)
    ref = reference.render([item], camera, options)
    out = _render(kind, [item], camera, options)
    assert psnr(out.rgba, ref.rgba) >= 60.0
    assert ref.rgba[..., 3].max() > 0.5 and (ref.rgba[..., 3] > 0.01).mean() > 0.3
    # the depth pass sees the same pixels (a pixel whose alpha is within rounding of 0.5 may differ)
    assert (np.isfinite(out.depth) == np.isfinite(ref.depth)).mean() > 0.999
