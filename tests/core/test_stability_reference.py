"""Numerical stability of the reference renderer: extreme and stiff inputs.

Every case checks that no pixel is NaN/Inf, alpha stays in [0, 1] and colours
are >= 0 (`sane`). Where the case is well defined, the image is compared with
an independent oracle (testing/reference_oracle.py: Sigma' = J W Sigma W^T J^T,
det = ac - b^2 in exact rational arithmetic, pixels in long double), within
TOL = 1e-6: the output is float32 (step 6e-8 below 1) and the float64 maths
loses far less, even for the stiff covariances.
"""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.camera import Camera, camera_from_params, look_at
from addon.core.reference import render
from addon.core.scene import RenderItem, RenderOptions
from addon.core.sh import C0
from addon.core.splats import SplatSet
from testing.reference_oracle import splat_alpha

TOL = 1e-6


def sane(out, cam):
    assert out.rgba.shape == (cam.height, cam.width, 4) and out.rgba.dtype == np.float32
    assert np.isfinite(out.rgba).all()
    assert (out.rgba[..., 3] >= 0).all() and (out.rgba[..., 3] <= 1).all()
    assert (out.rgba[..., :3] >= 0).all()
    assert not np.isnan(out.depth).any() and (out.depth > 0).all()


def make(positions, scales, rotations=None, opacities=0.9, rgb=(0.25, 0.5, 1.0)) -> SplatSet:
    pos = np.atleast_2d(np.asarray(positions, np.float64))
    s = SplatSet.allocate(len(pos), 0)
    s.positions[:] = pos
    s.scales[:] = np.broadcast_to(np.asarray(scales, np.float64), (len(pos), 3))
    if rotations is not None:
        s.rotations[:] = rotations
    s.opacities[:] = opacities
    s.sh_dc[:] = (np.asarray(rgb) - 0.5) / C0
    return s


def axis_camera(size=33, f=40.0, w2c=None, near=0.1) -> Camera:
    c = size / 2.0
    return Camera(np.eye(4) if w2c is None else np.asarray(w2c, float), size, size, f, f, c, c,
                  near, 1e9, False)


def check_single(cam, pos, scale, quat=(1, 0, 0, 0), opacity=0.9, world=None):
    s = make(pos, scale, quat, opacity)
    out = render([RenderItem(s, world=np.eye(4) if world is None else world)], cam, RenderOptions())
    sane(out, cam)
    expect, _ = splat_alpha(cam, s.positions[0], s.scales[0], s.rotations[0], s.opacities[0], world)
    np.testing.assert_allclose(out.rgba[..., 3], expect, atol=TOL)
    return out


@pytest.mark.parametrize("scale", [1e-8, 1e-6, 1e-3, 1.0, 1e3, 1e6])
def test_isotropic_scales_over_fourteen_decades(scale):
    out = check_single(axis_camera(), (0.02, -0.03, -10.0), scale)
    covered = (out.rgba[..., 3] > 0).sum()
    if scale <= 1e-3:  # sub-pixel: only the 0.3 px^2 low-pass footprint remains
        assert covered <= 25


ROTS = [(1, 0, 0, 0), (0.9, 0.3, -0.2, 0.1), (0.5, 0.5, 0.5, 0.5), (0.2, -0.7, 0.1, 0.6)]


@pytest.mark.parametrize("quat", ROTS)
@pytest.mark.parametrize("shape", ["needle", "disc"])
@pytest.mark.parametrize("long_axis", [0.5, 5e3, 1e6])
def test_anisotropy_1e8(quat, shape, long_axis):
    short = long_axis * 1e-8
    scale = (long_axis, short, short) if shape == "needle" else (long_axis, long_axis, short)
    out = check_single(axis_camera(), (0.1, 0.05, -5.0), scale, quat)
    if long_axis == 0.5 and shape == "needle":  # ~8 px long, ~1 px wide
        assert (out.rgba[..., 3] > 0).sum() < 200


def test_edge_on_disc_is_a_line():
    # Disc in the y-z plane seen edge-on: 1e8 anisotropy, a line of low-pass width.
    q = (np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0)  # 90 deg about y: local z -> camera x
    out = check_single(axis_camera(size=65), (0.0, 0.0, -5.0), (1.0, 1.0, 1e-8), q)
    covered = out.rgba[..., 3] > 0
    # 3 sigma = 24 px each way along the line; the width is the low-pass's
    assert covered.any(axis=1).sum() >= 40 and covered.any(axis=0).sum() <= 5


def test_opacity_logits_pm_1e4():
    with np.errstate(over="ignore"):
        opac = (1.0 / (1.0 + np.exp(-np.array([1e4, -1e4])))).astype(np.float32)
    assert opac[0] == 1.0 and opac[1] == 0.0
    cam = axis_camera()
    out = check_single(cam, (0, 0, -3), 0.05, opacity=opac[0])
    assert out.rgba[16, 16, 3] == pytest.approx(0.99, abs=TOL)
    bg = (0.1, 0.2, 0.3, 0.4)
    none = render([RenderItem(make([[0, 0, -3], [0.1, 0, -2]], 0.5, opacities=0.0))], cam,
                  RenderOptions(background=bg))
    sane(none, cam)
    assert np.array_equal(none.rgba, np.broadcast_to(np.float32(bg), none.rgba.shape))


def _far_scene(offset):
    """Two objects and a camera beside them, all moved by `offset`."""
    rng = np.random.default_rng(3)
    n = 150
    local = rng.normal(0, 0.5, (n, 3))
    q = rng.normal(size=(n, 4))
    a = make(local, 1.0, q / np.linalg.norm(q, axis=1, keepdims=True),
             rng.uniform(0.1, 1, n), (0.9, 0.3, 0.1))
    a.scales[:] = np.exp(rng.normal(-3.5, 0.5, (n, 3)))
    world = np.eye(4)
    world[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    world[:3, 3] = offset + (0.5, 0.0, 0.2)
    # Object b keeps its large coordinates in the float32 data: multiples of 1/16 near
    # 1e6 are exact in float32, so both scenes hold exactly the same splats.
    b_local = np.round(rng.normal(0, 0.8, (n, 3)) * 16) / 16
    b = make(b_local + offset, 0.03, opacities=0.7, rgb=(0.1, 0.4, 0.9))
    assert np.array_equal(b.positions.astype(np.float64) - offset, b_local)
    eye, target = np.array([3.0, -2.0, 1.0]), np.zeros(3)
    cam = axis_camera(size=64, f=60.0, w2c=look_at(eye + offset, target + offset))
    return [RenderItem(a, world=world), RenderItem(b)], cam


def test_far_from_origin_matches_origin():
    offset = np.array([1e6, -1e6, 1e6])
    far = render(*_far_scene(offset), RenderOptions())
    near = render(*_far_scene(np.zeros(3)), RenderOptions())
    sane(far, _far_scene(offset)[1])
    assert (near.rgba[..., 3] > 0.1).sum() > 200  # the comparison sees real content
    # float64 keeps ~1e6 * 2e-16 = 2e-10 units of the centres: invisible at 1e-6.
    np.testing.assert_allclose(far.rgba, near.rgba, atol=TOL)
    np.testing.assert_allclose(far.depth, near.depth, rtol=1e-6)  # float32 depth


def test_near_plane_straddling_and_behind():
    near = 0.125  # exact in float32, so the depths below are exact
    cam = axis_camera(near=near)
    depths = [-1.0, 0.0, 0.5 * near, near, 1.0001 * near, 0.2, 0.5]
    s = make([[0.01, -0.02, -d] for d in depths], 0.3, opacities=0.8)
    s.positions[0] = (0.0, 0.0, 1.0)  # behind the camera
    out = render([RenderItem(s)], cam, RenderOptions())
    sane(out, cam)
    in_front = np.array([d > near for d in depths])
    in_front[0] = False
    alone = render([RenderItem(s.subset(in_front))], cam, RenderOptions())
    assert np.array_equal(out.rgba, alone.rgba)
    behind = render([RenderItem(s.subset(~in_front))], cam, RenderOptions())
    assert not behind.rgba.any() and np.isinf(behind.depth).all()
    check_single(cam, (0.0, 0.0, -1.0001 * near), 0.3)  # straddles the near plane, on axis


def test_off_axis_straddling_splats_stay_finite():
    rng = np.random.default_rng(5)
    pos = np.c_[rng.uniform(-3, 3, (200, 2)), -rng.uniform(0.1, 0.3, 200)]
    cam = axis_camera()
    out = render([RenderItem(make(pos, 0.4, opacities=0.5))], cam, RenderOptions())
    sane(out, cam)


def test_camera_inside_a_splat():
    cam = axis_camera()
    out = check_single(cam, (0.0, 0.0, -1.0), 5.0, opacity=0.6)  # camera well inside 1 sigma
    assert out.rgba[..., 3].min() > 0.59
    inside_behind = render([RenderItem(make([0, 0, 1.0], 5.0))], cam, RenderOptions())
    assert not inside_behind.rgba.any()


def test_broken_values_are_culled():
    good = make([[0, 0, -3], [0.2, 0.1, -4]], 0.1, opacities=0.8)
    bad = make([[0, 0, -2]] * 9, 0.1, opacities=0.8)
    bad.rotations[0] = 0.0
    bad.rotations[1] = (np.nan, 0, 0, 0)
    bad.rotations[2] = (np.inf, 1, 0, 0)
    bad.scales[3] = (np.inf, 1, 1)
    bad.scales[4] = (np.nan, 1, 1)
    bad.positions[5] = (np.nan, 0, -2)
    bad.positions[6] = (np.inf, 0, -2)
    bad.opacities[7] = np.nan
    bad.sh_dc[8] = np.inf
    both = SplatSet(*(np.concatenate([getattr(good, f), getattr(bad, f)])
                      for f in ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")))
    cam = axis_camera()
    out = render([RenderItem(both)], cam, RenderOptions())
    sane(out, cam)
    assert np.array_equal(out.rgba, render([RenderItem(good)], cam, RenderOptions()).rgba)


@pytest.mark.parametrize("ortho_scale, scale", [(1e-6, 1e-8), (1e-6, 1e-2), (1e6, 1.0), (1e6, 1e5)])
def test_ortho_tiny_and_huge_scale(ortho_scale, scale):
    cam = camera_from_params(look_at((0, -5, 0), (0, 0, 0)), resolution_x=40, resolution_y=30,
                             ortho=True, ortho_scale=ortho_scale, clip_start=0.1, clip_end=100)
    pos = (ortho_scale * 0.05, 0.0, ortho_scale * -0.02)  # on screen, off centre
    check_single(cam, pos, scale, (0.9, 0.3, -0.2, 0.1))


def test_one_pixel_frame():
    cam = camera_from_params(np.eye(4), resolution_x=1, resolution_y=1)
    out = check_single(cam, (0, 0, -2), 0.01, opacity=0.7)
    assert out.rgba[0, 0, 3] == pytest.approx(0.7, abs=TOL)
    off = render([RenderItem(make([10, 0, -2], 0.01))], cam, RenderOptions())
    assert not off.rgba.any()


def test_8192_frame_with_a_handful_of_splats():
    cam = camera_from_params(np.eye(4), resolution_x=8192, resolution_y=8192, lens=50,
                             sensor_width=36)
    pos = [[0, 0, -2], [0.5, 0.3, -3], [-0.6, -0.6, -2.5], [0.71, -0.71, -2.0], [0, 0.1, -5]]
    out = render([RenderItem(make(pos, 1e-3, opacities=0.8))], cam, RenderOptions())
    alpha = out.rgba[..., 3]
    assert np.isfinite(out.rgba).all() and alpha.max() <= 0.99
    uv = cam.project(np.array(pos, np.float64))[:, :2]
    for u, v in uv:
        ok = 0 <= u < 8192 and 0 <= v < 8192
        assert not ok or alpha[int(v), int(u)] > 0.05
    # sigma = fx * 1e-3 / depth <= 5.7 px, so each covers < pi (3.4 sigma)^2 ~ 1200 px
    assert 0 < (alpha > 0).sum() < 5 * 1200
    del out


def test_no_splats():
    cam = axis_camera()
    bg = (0.0, 0.5, 0.25, 0.5)
    for items in ([], [RenderItem(SplatSet.empty(3))]):
        out = render(items, cam, RenderOptions(background=bg))
        sane(out, cam)
        assert np.array_equal(out.rgba, np.broadcast_to(np.float32(bg), out.rgba.shape))
        assert np.isinf(out.depth).all()
