"""Meshes hide splats (core): holdout_depth against a brute-force ray cast, and
the reference renderer's per-fragment holdout on random splats and on guitar.ply."""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import pytest

from addon.core import reference
from addon.core.camera import Camera, equirect_camera, look_at, simple_camera
from addon.core.dof import Defocus
from addon.core.holdout import Holdout, combine_alpha, combine_depth, holdout_depth
from addon.core.preprocess import project
from addon.core.scene import RenderItem, RenderOptions
from testing.gl_scenes import framing_camera, random_splats, world_for
from testing.holdout_scenes import guitar_scene, quad_mesh, triangulate

FULL = RenderOptions(early_termination=False)


# ---- holdout_depth against an independent oracle ----

def _pixel_rays_world(camera: Camera, window=None):
    """(H, W, 3) world ray origins and directions of the pixel centres, written from
    camera.py's and equirect.py's conventions (the camera-to-world matrix, not holdout.py)."""
    wx, wy, w, h = window or (0, 0, camera.width, camera.height)
    u, v = np.meshgrid(np.arange(wx, wx + w) + 0.5, np.arange(wy, wy + h) + 0.5)
    c2w = np.linalg.inv(camera.world_to_camera)
    zeros = np.zeros_like(u)
    if camera.equirect:
        lam, phi = (u - camera.cx) / camera.fx, (camera.cy - v) / camera.fy
        d = np.stack([np.cos(phi) * np.sin(lam), np.sin(phi), -np.cos(phi) * np.cos(lam)], -1)
        o = np.stack([zeros, zeros, zeros], -1)
    elif camera.ortho:
        o = np.stack([(u - camera.cx) / camera.fx, (camera.cy - v) / camera.fy, zeros], -1)
        d = np.broadcast_to([0.0, 0.0, -1.0], o.shape)
    else:
        d = np.stack([(u - camera.cx) / camera.fx, (camera.cy - v) / camera.fy, zeros - 1], -1)
        o = np.stack([zeros, zeros, zeros], -1)
    return o @ c2w[:3, :3].T + c2w[:3, 3], d @ c2w[:3, :3].T


def brute_force_depth(triangles, camera: Camera, window=None) -> np.ndarray:
    """Every pixel ray against every triangle: solve o + t d = v0 + a e1 + b e2 (a 3x3
    linear system), hit where a, b >= 0, a + b <= 1; depth measured in world space:
    -z of the hit in camera space, or its distance for an equirect camera."""
    o, d = _pixel_rays_world(camera, window)
    best = np.full(o.shape[:2], np.inf)
    w2c = camera.world_to_camera
    eye = np.linalg.inv(w2c)[:3, 3]
    for v0, v1, v2 in np.asarray(triangles, np.float64):
        m = np.stack([np.broadcast_to(v1 - v0, d.shape), np.broadcast_to(v2 - v0, d.shape), -d], -1)
        ok = np.abs(np.linalg.det(m)) > 1e-300
        sol = np.full(d.shape, np.nan)
        sol[ok] = np.linalg.solve(m[ok], (o - v0)[ok][..., None])[..., 0]
        a, b = sol[..., 0], sol[..., 1]
        p = v0 + a[..., None] * (v1 - v0) + b[..., None] * (v2 - v0)
        depth = np.linalg.norm(p - eye, axis=-1) if camera.equirect else -(p @ w2c[2, :3] + w2c[2, 3])
        with np.errstate(invalid="ignore"):
            hit = ((a >= 0) & (b >= 0) & (a + b <= 1) & (sol[..., 2] > 0)  # forward along the ray
                   & (depth > camera.near) & (depth <= camera.far))
        best = np.where(hit, np.minimum(best, depth), best)
    return best


def _triangles(rng, eye, forward, n=10):
    """n random triangles in front of `eye` plus one big one crossing the camera plane."""
    centres = eye + forward * rng.uniform(2.0, 8.0, (n, 1)) + rng.normal(0.0, 1.5, (n, 3))
    tri = centres[:, None, :] + rng.normal(0.0, 1.2, (n, 3, 3))
    crossing = np.array([[eye + forward * 3.0 + (3.0, 0.5, 1.0), eye - forward * 2.0 + (-1.0, 0.3, 0.2),
                          eye + forward * 5.0 + (-2.5, -0.4, -1.5)]])
    return np.concatenate([tri, crossing])


def _cameras():
    rng = np.random.default_rng(7)
    eye = np.array([1.0, -2.0, 0.5])
    target = eye + np.array([0.4, 1.0, -0.2])
    rolled = look_at(eye, target, up=(0.3, 0.1, 1.0))  # rotated about every axis
    forward = (target - eye) / np.linalg.norm(target - eye)
    persp = Camera(rolled, 64, 40, 52.0, 55.0, 30.0, 22.0, 0.5, 50.0)  # off-centre, fx != fy
    ortho = Camera(rolled, 48, 36, 7.0, 7.5, 25.0, 17.0, 0.5, 50.0, ortho=True)
    equi = equirect_camera(rolled, 96, 48, near=0.5, far=50.0)
    c2w = np.linalg.inv(rolled)
    # camera space: two corners ahead on the left, one behind the camera on the right; the
    # visible part runs off the frame's right edge while the corner behind projects far
    # left: only clipping at the near plane gives its screen box
    behind = np.array([[[-1.0, -0.2, -4.0], [-1.2, 1.0, -4.5], [2.0, 0.5, 1.0]]])
    tri = np.concatenate([_triangles(rng, eye, forward), behind @ c2w[:3, :3].T + c2w[:3, 3]])
    # equirect: triangles all around, one across the +-180 degree seam (behind the camera),
    # one over a pole, one enclosing the camera's direction cone widely
    back, up = c2w[:3, 2], c2w[:3, 1]
    around = eye + rng.normal(0.0, 4.0, (8, 1, 3)) + rng.normal(0.0, 1.0, (8, 3, 3))
    seam = np.array([[eye + 4 * back + (1.5, 0.0, 0.0) + up, eye + 4 * back - (1.5, 0.0, 0.0),
                      eye + 4 * back - up + (0.2, 0.9, 0.1)]])
    pole = eye + 3 * up + np.array([[[2.0, 0.0, 0.0], [-1.0, 1.7, 0.1], [-1.0, -1.7, -0.2]]])
    wide = eye + np.array([[[-6.0, 5.0, 3.0], [6.0, 5.0, 2.0], [0.0, -7.0, -1.0]]])
    return {"perspective": (persp, tri), "ortho": (ortho, tri),
            "equirect": (equi, np.concatenate([tri, around, seam, pole, wide]))}


@pytest.mark.parametrize("kind", ["perspective", "ortho", "equirect"])
def test_holdout_depth_matches_brute_force(kind):
    camera, tri = _cameras()[kind]
    got = holdout_depth(Holdout(tri), camera)
    want = brute_force_depth(tri, camera)
    assert got.shape == (camera.height, camera.width) and got.dtype == np.float64
    hit = np.isfinite(want)
    assert 0.15 < hit.mean() < 0.98  # the triangles cover some, not all, of the frame
    np.testing.assert_array_equal(np.isfinite(got), hit)
    np.testing.assert_allclose(got[hit], want[hit], rtol=0, atol=1e-9)
    # with depth of field the surface is seen along the pinhole ray
    if kind == "perspective":
        blurred = replace(camera, defocus=Defocus(0.2, 4.0))
        np.testing.assert_array_equal(holdout_depth(Holdout(tri), blurred), got)
    # a window is that crop of the frame, exactly
    win = (5, 3, 30, 20)
    np.testing.assert_array_equal(holdout_depth(Holdout(tri), camera, win),
                                  got[3:23, 5:35])


def test_holdout_depth_near_and_far_and_both_faces():
    """A triangle counts from both sides; hits at depth <= near or > far do not."""
    cam = simple_camera(20, 20, 60.0, look_at((0, 0, 0), (0, 1, 0)), near=1.0, far=10.0)
    quad = lambda y: triangulate(*quad_mesh((0, y, 0), (50, 0, 0), (0, 0, 50)))
    for y in (0.5, 1.0, 10.5):
        assert np.isinf(holdout_depth(Holdout(quad(y)), cam)).all()
    flipped = quad(4.0)[:, ::-1]  # the same quad, facing away
    for tri in (quad(4.0), flipped):
        np.testing.assert_allclose(holdout_depth(Holdout(tri), cam), 4.0, rtol=1e-15)
    np.testing.assert_allclose(holdout_depth(Holdout(quad(10.0)), cam), 10.0, rtol=1e-15)
    assert np.isinf(holdout_depth(Holdout(np.zeros((0, 3, 3))), cam)).all()


def test_holdout_key_equality_and_validation():
    tri = np.random.default_rng(1).normal(size=(5, 3, 3))
    a, b = Holdout(tri), Holdout(tri.copy())
    assert a == b and hash(a) == hash(b) and a.count == 5 and a.key == b.key
    c = Holdout(tri + 1e-12)
    assert c != a
    assert RenderOptions(holdout=a) == RenderOptions(holdout=b)
    assert hash(RenderOptions(holdout=a)) == hash(RenderOptions(holdout=b))
    assert RenderOptions(holdout=a) != RenderOptions(holdout=c) != RenderOptions()
    assert not a.triangles.flags.writeable and a.triangles.flags.c_contiguous
    with pytest.raises(ValueError, match="shape"):
        Holdout(np.zeros((4, 3)))
    with pytest.raises(ValueError, match="non-finite"):
        Holdout(np.full((1, 3, 3), np.nan))


def test_holdout_depth_10k_triangles_is_fast():
    rng = np.random.default_rng(3)
    tri = (rng.normal(size=(10_000, 1, 3)) * (2.0, 1.0, 2.0) + (0.0, 6.0, 0.0)
           + rng.normal(0.0, 0.05, (10_000, 3, 3)))
    cam = simple_camera(320, 180, 60.0, look_at((0, 0, 0), (0, 1, 0)))
    start = time.perf_counter()
    depth = holdout_depth(Holdout(tri), cam)
    assert time.perf_counter() - start < 10.0  # measured ~0.05 s
    assert 0.2 < np.isfinite(depth).mean() < 0.9


def test_combine_depth_and_alpha():
    splat_z = np.array([2.0, 2.0, np.inf, 3.0, 7.0])
    splat_a = np.array([0.9, 0.3, 0.1, 0.6, 0.8])
    mesh_z = np.array([5.0, 5.0, 4.0, 1e10, 6.0])
    np.testing.assert_array_equal(combine_depth(splat_z, splat_a, mesh_z),
                                  [2.0, 5.0, 4.0, 3.0, 6.0])
    np.testing.assert_allclose(combine_alpha(np.array([0.0, 0.5, 1.0]), np.array([1.0, 1.0, 0.3])),
                               [1.0, 1.0, 1.0])
    np.testing.assert_allclose(combine_alpha(0.25, 0.5), 0.625)


# ---- the reference renderer with a holdout: random splats ----

def _blob():
    sp = random_splats(700, 1, seed=4, spread=0.5, log_scale=-3.0)
    item = RenderItem(sp, world=world_for(sp))
    return item, framing_camera(item, 48, 36, direction=(0.4, -1.0, 0.3))


def _plane_at_depth(camera: Camera, depth: float, u_range=(-1e3, 1e3)):
    """A screen-aligned rectangle at camera depth `depth` over the columns u in u_range."""
    c2w = np.linalg.inv(camera.world_to_camera)
    u = np.array(u_range, np.float64)
    x = (np.clip(u, -1e3, 1e3) - camera.cx) / camera.fx * depth
    y = np.array([-1e3, 1e3]) * depth / camera.fy
    corners = np.array([[x[0], y[0], -depth], [x[1], y[0], -depth], [x[1], y[1], -depth],
                        [x[0], y[1], -depth]])
    world = corners @ c2w[:3, :3].T + c2w[:3, 3]
    return triangulate(world, [(0, 1, 2, 3)])


def _front_only(item, camera, depth_limit):
    """The item with only the splats whose centre depth is below depth_limit (a subset)."""
    z = project(item, camera).depth
    return replace(item, splats=item.splats.subset(np.nonzero(z < depth_limit)[0]))


@pytest.mark.parametrize("options", [FULL, RenderOptions()], ids=["full", "early_termination"])
def test_plane_over_the_whole_frame_keeps_exactly_the_splats_in_front(options):
    item, cam = _blob()
    z = project(item, cam).depth
    cut = float(np.median(z))
    hold = Holdout(_plane_at_depth(cam, cut))
    assert np.isfinite(holdout_depth(hold, cam)).all()
    got = reference.render([item], cam, replace(options, holdout=hold))
    want = reference.render([_front_only(item, cam, cut)], cam, options)
    plain = reference.render([item], cam, options)
    np.testing.assert_array_equal(got.rgba, want.rgba)
    np.testing.assert_array_equal(got.depth, want.depth)
    assert np.abs(plain.rgba - got.rgba).max() > 0.1  # the plane hides something


def test_plane_over_half_the_frame():
    item, cam = _blob()
    cut = float(np.median(project(item, cam).depth))
    hold = Holdout(_plane_at_depth(cam, cut, u_range=(-1e3, 24.0)))
    mask = np.isfinite(holdout_depth(hold, cam))
    np.testing.assert_array_equal(mask, np.broadcast_to(np.arange(48) < 24, mask.shape))
    got = reference.render([item], cam, replace(FULL, holdout=hold))
    plain = reference.render([item], cam, FULL)
    front = reference.render([_front_only(item, cam, cut)], cam, FULL)
    np.testing.assert_array_equal(got.rgba[mask], front.rgba[mask])
    np.testing.assert_array_equal(got.rgba[~mask], plain.rgba[~mask])
    np.testing.assert_array_equal(got.depth[~mask], plain.depth[~mask])
    assert np.abs(plain.rgba[mask] - got.rgba[mask]).max() > 0.1


def test_tilted_plane_hides_per_fragment():
    """Each pixel keeps exactly the splats in front of the surface AT THAT PIXEL: pixel by
    pixel, the holdout render equals a 1x1 window render of the splats whose centre depth
    is below that pixel's holdout depth. A tilted plane's depth varies across the frame,
    so the same splat is hidden at some of its pixels and drawn at others."""
    sp = random_splats(250, 0, seed=5, spread=0.5, log_scale=-2.6)
    item = RenderItem(sp, world=world_for(sp))
    cam = framing_camera(item, 20, 14, direction=(0.4, -1.0, 0.3))
    z = project(item, cam).depth
    c2w = np.linalg.inv(cam.world_to_camera)
    mid = float(np.median(z))
    # camera space: a plane through the middle, its depth running from near to far across x
    corners = np.array([[-50.0, -50.0, -mid + 0.6 * 50], [50.0, -50.0, -mid - 0.6 * 50],
                        [50.0, 50.0, -mid - 0.6 * 50], [-50.0, 50.0, -mid + 0.6 * 50]])
    hold = Holdout(triangulate(corners @ c2w[:3, :3].T + c2w[:3, 3], [(0, 1, 2, 3)]))
    held = holdout_depth(hold, cam)
    assert np.isfinite(held).all() and np.ptp(held) > 0.5 * np.ptp(z)
    got = reference.render([item], cam, replace(FULL, holdout=hold))
    for y in range(cam.height):
        for x in range(cam.width):
            one = reference.render([_front_only(item, cam, held[y, x])], cam, FULL, window=(x, y, 1, 1))
            np.testing.assert_array_equal(got.rgba[y, x], one.rgba[0, 0])
            np.testing.assert_array_equal(got.depth[y, x], one.depth[0, 0])
    # the same splat is hidden at one pixel and kept at another
    split = ((z > held.min()) & (z < held.max())).sum()
    assert split > 50


# ---- the reference with a holdout: guitar.ply with a cube in front, one behind, a plane ----

@pytest.fixture(scope="module")
def guitar(testdata):
    scene = guitar_scene(testdata, 96, 64)
    plain = reference.render(scene.items, scene.camera)
    held = reference.render(scene.items, scene.camera, RenderOptions(holdout=scene.holdout))
    depth = {n: holdout_depth(Holdout(t), scene.camera) for n, t in scene.triangles.items()}
    return scene, plain, held, depth


def test_guitar_front_cube_hides_the_guitar(guitar):
    scene, plain, held, depth = guitar
    front = np.isfinite(depth["front_cube"])
    under = front & (plain.rgba[..., 3] > 0.9)  # the guitar, opaque, behind the cube
    assert under.sum() > 40
    # only the few splats nearer than the cube are left there
    assert held.rgba[..., 3][under].mean() < 0.1 * plain.rgba[..., 3][under].mean()
    assert held.rgba[..., 3][under].max() < 0.5
    # and what is left lies in front of the cube
    fin = front & np.isfinite(held.depth)
    assert (held.depth[fin] < depth["front_cube"][fin]).all()


def test_guitar_back_cube_changes_nothing_where_the_guitar_is_opaque(guitar):
    scene, plain, held, depth = guitar
    back = np.isfinite(depth["back_cube"]) & ~np.isfinite(depth["front_cube"])
    back &= ~np.isfinite(depth["plane"])
    opaque = back & (plain.rgba[..., 3] > 0.999)
    assert opaque.sum() > 20 and (back & (plain.rgba[..., 3] < 0.5)).sum() > 20
    np.testing.assert_allclose(held.rgba[opaque], plain.rgba[opaque], atol=1e-3)
    np.testing.assert_allclose(held.depth[opaque], plain.depth[opaque], rtol=1e-3)
    # away from every surface, nothing at all changes
    none = ~np.any([np.isfinite(d) for d in depth.values()], axis=0)
    np.testing.assert_array_equal(held.rgba[none], plain.rgba[none])
    # depth decides, not coverage: the same cube pulled towards the camera (scaled about
    # its centre of projection, so it covers the same pixels) hides the guitar there
    eye = scene.camera.position
    pulled = Holdout(eye + 0.45 * (scene.triangles["back_cube"] - eye))
    ys, xs = np.nonzero(opaque)
    win = (int(xs.min()), int(ys.min()), int(np.ptp(xs)) + 1, int(np.ptp(ys)) + 1)
    near = reference.render(scene.items, scene.camera, RenderOptions(holdout=pulled), window=win)
    crop = opaque[win[1]:win[1] + win[3], win[0]:win[0] + win[2]]
    assert near.rgba[..., 3][crop].max() < 0.5


def test_guitar_plane_through_the_middle_cuts_per_fragment(guitar):
    scene, plain, held, depth = guitar
    plane = np.isfinite(depth["plane"]) & ~np.isfinite(depth["front_cube"])
    guitar_px = plane & (plain.rgba[..., 3] > 0.5)
    assert guitar_px.sum() > 40
    # the plane passes through the neck: at some of its pixels the guitar stays, at
    # others it is cut away
    a = held.rgba[..., 3][guitar_px]
    assert (a > 0.5).sum() > 5 and (a < 0.1 * plain.rgba[..., 3][guitar_px]).sum() > 5
    fin = plane & np.isfinite(held.depth)
    assert fin.any() and (held.depth[fin] < depth["plane"][fin]).all()
