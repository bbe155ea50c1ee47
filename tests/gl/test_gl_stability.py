"""Extreme and stiff inputs for the offscreen renderer: no NaN/Inf pixel, alpha in [0, 1],
no splat covering the frame because of broken math, and, where the case is well defined,
agreement with the float64 reference (same PSNR bar as test_gl_render.py, which explains it).
"""
from __future__ import annotations

import numpy as np
import pytest

from addon.core import reference
from addon.core.camera import Camera, look_at, simple_camera
from addon.core.scene import RenderItem, RenderOptions
from addon.core.splats import SplatSet
from testing.gl_scenes import psnr, random_splats

MIN_PSNR = 60.0
EYE = look_at((0.0, -5.0, 0.0), (0.0, 0.0, 0.0))  # looks along +y


def check_sane(out, height, width):
    assert out.rgba.shape == (height, width, 4) and out.depth.shape == (height, width)
    assert np.isfinite(out.rgba).all()
    assert not np.isnan(out.depth).any()  # inf is allowed: "never reached 0.5"
    a = out.rgba[..., 3]
    assert a.min() >= 0.0 and a.max() <= 1.0
    assert (out.rgba[..., :3] >= 0.0).all()


def compare(renderer, items, cam, options=RenderOptions(), min_psnr=MIN_PSNR):
    out = renderer.render(items, cam, options)
    check_sane(out, cam.height, cam.width)
    ref = reference.render(items, cam, options)
    assert psnr(out.rgba, ref.rgba) >= min_psnr
    return out, ref


def splats(positions, scales, rotations=None, opacity=0.9, colour=(1.0, 0.0, -1.0)):
    n = len(positions)
    s = SplatSet.allocate(n, 0)
    s.positions[:] = positions
    s.scales[:] = scales
    if rotations is not None:
        s.rotations[:] = rotations
    s.opacities[:] = opacity
    s.sh_dc[:] = colour
    return s


def cam(w=64, h=48, world_to_camera=EYE, near=0.1):
    return simple_camera(w, h, 60.0, world_to_camera, near=near, far=1e9)


def test_scales_from_1e_minus8_to_1e6(renderer):
    scales = np.logspace(-8, 6, 15)
    pos = np.stack([np.linspace(-2, 2, 15), np.zeros(15), np.linspace(-1, 1, 15)], 1)
    s = splats(pos, np.repeat(scales[:, None], 3, 1), opacity=0.5)
    out, _ = compare(renderer, [RenderItem(s)], cam())
    # the 1e6 splat encloses the camera: it legitimately covers the frame
    assert out.rgba[..., 3].min() > 0.4


def test_only_tiny_splats_stay_tiny(renderer):
    """Scales 1e-8..1e-3 must not grow into screen-covering quads."""
    scales = np.logspace(-8, -3, 6)
    pos = np.stack([np.linspace(-1, 1, 6), np.zeros(6), np.zeros(6)], 1)
    s = splats(pos, np.repeat(scales[:, None], 3, 1))
    out, _ = compare(renderer, [RenderItem(s)], cam())
    # a vanishing splat is the 0.3 px^2 low-pass alone: lambda = 0.3 + sqrt(0.1), so its
    # quad's half-size is 3 sqrt(lambda) = 2.35 px, at most 5 x 5 pixel centres
    assert (out.rgba[..., 3] > 1 / 255).sum() <= 6 * 25


@pytest.mark.parametrize("shape", [(1e4, 1e-4, 1e-4), (1e2, 1e2, 1e-6), (1e-3, 1e-3, 1e5)],
                         ids=["needle", "disc", "needle-along-view"])
def test_anisotropy_1e8(renderer, shape):
    rng = np.random.default_rng(3)
    q = rng.normal(size=(24, 4))
    pos = rng.uniform(-1.5, 1.5, (24, 3)) * (1, 0.2, 1)
    s = splats(pos, np.tile(np.float32(shape) * 1e-2, (24, 1)), q / np.linalg.norm(q, axis=1, keepdims=True),
               opacity=0.6)
    compare(renderer, [RenderItem(s)], cam())


def test_opacity_logits_plus_minus_1e4(renderer):
    s = random_splats(200, 0, seed=4)
    logits = np.where(np.arange(200) % 2 == 0, 1e4, -1e4)
    with np.errstate(over="ignore"):
        s.opacities[:] = (1.0 / (1.0 + np.exp(-logits))).astype(np.float32)
    assert set(np.unique(s.opacities)) == {0.0, 1.0}
    out, _ = compare(renderer, [RenderItem(s)], cam())
    assert out.rgba[..., 3].max() > 0.9


@pytest.mark.parametrize("where", ["object-translation", "data"])
def test_positions_1e6_from_origin(renderer, where):
    """The far scene must look like the same scene at the origin (float64 reference)."""
    s = random_splats(300, 1, seed=6)
    far = np.array([1e6, -1e6, 1e6])
    near_item = RenderItem(s, sh_degree=1)
    at_origin = reference.render([near_item], cam(), RenderOptions())
    world_to_camera = EYE.copy()
    world_to_camera[:3, 3] -= EYE[:3, :3] @ far  # the camera moved by `far` too
    if where == "data":
        moved = SplatSet(**{**s.__dict__, "positions": (s.positions + far).astype(np.float32)})
        item = RenderItem(moved, sh_degree=1)
        # float32 data at 1e6 holds positions to 1/16: compare with the same rounded data
        at_origin = reference.render([RenderItem(SplatSet(**{**s.__dict__, "positions": (
            moved.positions.astype(np.float64) - far).astype(np.float32)}), sh_degree=1)], cam(), RenderOptions())
    else:
        world = np.eye(4)
        world[:3, 3] = far
        item = RenderItem(s, world=world, sh_degree=1)
    out = renderer.render([item], cam(world_to_camera=world_to_camera), RenderOptions())
    check_sane(out, 48, 64)
    assert psnr(out.rgba, at_origin.rgba) >= MIN_PSNR


def test_splats_behind_and_straddling_the_near_plane(renderer):
    # camera at y=-5 looking +y with near 0.5: centres at depths -1 .. 1.5 around the plane
    depths = np.linspace(-1.0, 1.5, 11)
    pos = np.stack([np.linspace(-0.3, 0.3, 11), -5.0 + depths, np.zeros(11)], 1)
    s = splats(pos, np.full((11, 3), 0.4), opacity=0.7)
    out, ref = compare(renderer, [RenderItem(s)], cam(near=0.5))
    assert out.rgba[..., 3].max() > 0.5  # the ones beyond the near plane are drawn


def test_camera_inside_a_splat(renderer):
    s = splats([(0.0, -5.0, 0.0), (0.3, 1.0, 0.0)], [(3.0, 3.0, 3.0), (0.5, 0.5, 0.5)], opacity=0.8)
    s.positions[0] = (0.0, -4.5, 0.0)  # centre just in front of the camera, camera inside it
    compare(renderer, [RenderItem(s)], cam())


def test_nan_and_zero_quaternions_are_culled(renderer):
    s = random_splats(100, 0, seed=8)
    s.rotations[::3] = np.nan
    s.rotations[1::3] = 0.0
    s.scales[5] = np.inf
    s.positions[7] = np.nan
    out, ref = compare(renderer, [RenderItem(s)], cam())
    good = s.subset(np.arange(100) % 3 == 2)
    assert psnr(out.rgba, reference.render([RenderItem(good)], cam()).rgba) >= MIN_PSNR


@pytest.mark.parametrize("ortho_scale", [1e-6, 1e6])
def test_orthographic_tiny_and_huge(renderer, ortho_scale):
    s = random_splats(200, 2, seed=9, spread=ortho_scale * 0.3, log_scale=np.log(ortho_scale * 0.02))
    w, h = 48, 32
    fx = w / ortho_scale
    c = Camera(EYE, w, h, fx, fx, w / 2, h / 2, 0.1, 1e9, ortho=True)
    out, _ = compare(renderer, [RenderItem(s, sh_degree=2)], c)
    assert out.rgba[..., 3].max() > 0.3


def test_ortho_huge_scale_sees_subpixel_splats(renderer):
    s = random_splats(200, 0, seed=10)
    c = Camera(EYE, 32, 32, 32 / 1e6, 32 / 1e6, 16, 16, 0.1, 1e9, ortho=True)
    out, _ = compare(renderer, [RenderItem(s)], c)
    # every centre lands within 1e-5 px of the frame centre; quads are <= 2.35 px (see above)
    lit = np.argwhere(out.rgba[..., 3] > 1 / 255)
    assert lit.size and np.abs(lit + 0.5 - 16).max() <= 2.35


def test_one_by_one_frame(renderer):
    s = random_splats(50, 0, seed=11)
    out, _ = compare(renderer, [RenderItem(s)], cam(1, 1))
    assert out.rgba.shape == (1, 1, 4)


def test_8192_square_frame_few_splats(renderer):
    """Drawn in 4096 tiles; checked whole for sanity and on a crop against the reference."""
    s = random_splats(20, 0, seed=12, log_scale=-2.5)
    big = cam(8192, 8192)
    out = renderer.render([RenderItem(s)], big)
    check_sane(out, 8192, 8192)
    assert (out.rgba[..., 3] > 0.1).sum() > 1000
    # the reference renders a window of the same 8192 frame (same J clamp), exactly
    x0, y0, w, h = 4000, 3900, 256, 256
    ref = reference.render([RenderItem(s)], big, window=(x0, y0, w, h))
    got = out.rgba[y0:y0 + h, x0:x0 + w]
    assert ref.rgba[..., 3].max() > 0.1
    assert psnr(got, ref.rgba) >= MIN_PSNR
    del out


def test_zero_splats(renderer):
    out = renderer.render([RenderItem(SplatSet.empty())], cam())
    check_sane(out, 48, 64)
    assert not out.rgba.any() and np.isinf(out.depth).all()
