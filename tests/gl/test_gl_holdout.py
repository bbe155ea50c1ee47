"""Meshes hide splats in the offscreen GL renderer, as the float64 reference
does: options.holdout's triangles drawn into a surface depth map (gl/holdout.py), and
every splat fragment whose centre is not in front of the surface there dropped by the
depth test (gl/composite.py), on the compute path and the GL 3.3 fallback.

Bars. The surface map is the reference's ray cast in float32: the same pixels covered,
depths within 2e-6 relative (4e-6 of the scene's size near the camera). Frames: PSNR
>= 45 dB against the reference with the same holdout, over the colour and over the alpha
alone. Measured (llvmpipe, both paths): colour 80.5 / 83.2 / 94.4-96.1 dB and alpha
76.6 / 79.0 / 88.9-90.8 dB for perspective / ortho / equirect with early termination
(batch stop against the reference's exact stop dominates), 90.8 and 87.0 dB without it,
85.2 dB with depth of field: the discrete events of test_gl_render.py's docstring, plus a
fragment whose centre lies within float32 rounding or held_band (2.4e-6 of the depth
span) of the surface falling on the other side. The plain frame scores 20.9-34.5 dB
against the held-out reference, so a renderer ignoring the holdout fails the bar.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from addon.core import reference, shutter
from addon.core.camera import Camera, equirect_camera, look_at, simple_camera
from addon.core.dof import Defocus
from addon.core.holdout import Holdout, holdout_depth
from addon.core.scene import RenderItem, RenderOptions
from addon.core.splats import SplatSet
from addon.gl import OffscreenRenderer
from addon.gl.holdout import depth_bounds, depth_encoding, held_band
from testing.gl_scenes import assert_depth_matches, psnr
from testing.holdout_scenes import guitar_scene, quad_mesh, triangulate

MIN_PSNR = 45.0
PATHS = ["compute", "gl33"]
KINDS = ["perspective", "ortho", "equirect"]


@pytest.fixture(scope="module")
def renderers():
    out = {"compute": OffscreenRenderer(), "gl33": OffscreenRenderer(compute=False)}
    assert out["compute"].uses_compute and not out["gl33"].uses_compute
    yield out
    for r in out.values():
        r.close()


@pytest.fixture(scope="module")
def scene(testdata):
    return guitar_scene(testdata, 160, 96, every=2)


def camera_of(scene, kind: str) -> Camera:
    """The scene's camera, or one of the other kinds: an orthographic one as wide as the
    guitar seen from the same place, an equirect one close to the guitar, so the surfaces
    cover much of the panorama."""
    cam = scene.camera
    if kind == "ortho":
        scale = 1.25 * scene.size  # the distance to the guitar: the same picture at its depth
        return Camera(cam.world_to_camera, cam.width, cam.height, cam.fx / scale, cam.fy / scale,
                      cam.cx, cam.cy, cam.near, cam.far, ortho=True)
    if kind == "equirect":
        view = scene.centre - cam.position
        return equirect_camera(look_at(scene.centre - 0.3 * view, scene.centre, up=(1.0, 0.0, 0.0)),
                               cam.width, cam.height, near=cam.near, far=cam.far)
    return cam


@pytest.fixture(scope="module")
def references(scene):
    """Reference frames per (camera kind, early termination): with and without the holdout."""
    cache = {}

    def get(kind: str, early: bool = True):
        if (kind, early) not in cache:
            cam = camera_of(scene, kind)
            cache[kind, early] = tuple(reference.render(scene.items, cam, RenderOptions(
                holdout=h, early_termination=early)) for h in (scene.holdout, None))
        return cache[kind, early]
    return get


# ---- the surface depth map ----

def map_cameras_and_triangles(scene):
    """Every camera kind with the scene's surfaces plus triangles that test the edges of
    the map: one reaching behind the camera (perspective: clipped at the clip start), and
    for the panorama one across the +-180 degree seam behind it, one over a pole and one
    around the camera's whole field."""
    out = {}
    for kind in KINDS:
        cam = camera_of(scene, kind)
        c2w = np.linalg.inv(cam.world_to_camera)
        to_world = lambda p: np.asarray(p, np.float64) @ c2w[:3, :3].T + c2w[:3, 3]
        d = 0.3 * scene.size
        extra = [to_world([[-d, -0.3 * d, -2 * d], [-1.2 * d, d, -2.5 * d], [2 * d, 0.5 * d, d]])]
        if kind == "equirect":
            extra += [to_world([[d, 0.2 * d, 2 * d], [-d, 0.1 * d, 2.2 * d], [0.1 * d, -d, 1.8 * d]]),
                      to_world([[d, 2 * d, 0.0], [-0.5 * d, 2.1 * d, 0.9 * d], [-0.5 * d, 1.9 * d, -0.9 * d]]),
                      to_world([[-4 * d, -3 * d, -3 * d], [4 * d, -3 * d, -2 * d], [0.0, 5 * d, 1 * d]])]
        out[kind] = (cam, Holdout(np.concatenate([scene.holdout.triangles] + [e[None] for e in extra])))
    return out


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("kind", KINDS)
def test_surface_map_is_the_reference_ray_cast(renderers, scene, kind, path):
    """The map holds the nearest hit of each pixel-centre ray, in the splats' depth
    measure: the same pixels as core.holdout_depth, depths within float32 rounding."""
    cam, held = map_cameras_and_triangles(scene)[kind]
    got = renderers[path].holdout_depth(held, cam)
    want = holdout_depth(held, cam)
    hit = np.isfinite(want)
    assert 0.05 < hit.mean() < 0.98
    np.testing.assert_array_equal(np.isfinite(got), hit)
    # float32 camera-space corners: rounding ~1e-7 of the scene's size, relative where far
    np.testing.assert_allclose(got[hit], want[hit], rtol=2e-6, atol=4e-6 * scene.size)
    if kind == "perspective":  # depth of field: the pinhole's map, as the reference's
        blurred = replace(cam, defocus=Defocus(0.05 * scene.size, 1.25 * scene.size))
        np.testing.assert_array_equal(renderers[path].holdout_depth(held, blurred), got)


# ---- frames against the reference ----

def assert_matches(out, ref, plain_ref):
    for got, want, other in ((out.rgba, ref.rgba, plain_ref.rgba),
                             (out.rgba[..., 3], ref.rgba[..., 3], plain_ref.rgba[..., 3])):
        assert psnr(got, want) >= MIN_PSNR, psnr(got, want)
        assert psnr(other, want) < MIN_PSNR - 10  # the holdout matters in this frame
    assert ref.rgba[..., 3].max() > 0.5


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("kind", KINDS)
def test_frame_against_reference(renderers, scene, references, kind, path):
    cam = camera_of(scene, kind)
    options = RenderOptions(holdout=scene.holdout)
    out = renderers[path].render(scene.items, cam, options)
    ref, plain_ref = references(kind)
    assert_matches(out, ref, plain_ref)
    if kind != "equirect":
        assert_depth_matches(out, scene.items, cam, options)
    else:  # the guitar covers 3% of the panorama, under assert_depth_matches' 5%
        full = reference.render(scene.items, cam, replace(options, early_termination=False))
        both = np.isfinite(full.depth) & np.isfinite(out.depth)
        assert both.sum() > 200 and np.mean(np.isfinite(full.depth) != np.isfinite(out.depth)) < 1e-3
        err = np.abs(out.depth[both] - full.depth[both]) / full.depth[both]
        assert np.quantile(err, 0.99) < 1e-4 and err.max() < 0.02


@pytest.mark.parametrize("path", PATHS)
def test_frame_without_early_termination(renderers, scene, references, path):
    """Early termination off: on the compute path the batches still close the cells
    hidden behind the surface, and nothing saturates."""
    options = RenderOptions(holdout=scene.holdout, early_termination=False)
    out = renderers[path].render(scene.items, scene.camera, options)
    ref, plain_ref = references("perspective", early=False)
    assert_matches(out, ref, plain_ref)


@pytest.mark.parametrize("path", PATHS)
def test_front_cube_holds_the_guitar_out(renderers, scene, path):
    """Behind the front cube only the few splats nearer than it are left; where the plane
    cuts the neck some of the guitar stays and some goes; away from every surface the
    frame is the plain frame."""
    r, cam = renderers[path], scene.camera
    held = r.render(scene.items, cam, RenderOptions(holdout=scene.holdout))
    plain = r.render(scene.items, cam, RenderOptions())
    depth = {n: holdout_depth(Holdout(t), cam) for n, t in scene.triangles.items()}
    front = np.isfinite(depth["front_cube"])
    under = front & (plain.rgba[..., 3] > 0.9)
    assert under.sum() > 100
    assert held.rgba[..., 3][under].mean() < 0.1 * plain.rgba[..., 3][under].mean()
    plane = np.isfinite(depth["plane"]) & ~front & (plain.rgba[..., 3] > 0.5)
    a = held.rgba[..., 3][plane] / plain.rgba[..., 3][plane]
    assert (a > 0.9).sum() > 20 and (a < 0.1).sum() > 20
    # away from every surface: the plain frame, up to the float32 rounding of quads the
    # compute path's culling cut to their open cells (as early termination does)
    none = ~np.any([np.isfinite(d) for d in depth.values()], axis=0)
    assert none.mean() > 0.3
    diff = np.abs(held.rgba[none] - plain.rgba[none])
    assert diff.max() < 1e-4 if path == "compute" else diff.max() == 0


@pytest.mark.parametrize("path", PATHS)
def test_no_holdout_empty_or_unseen_is_bit_identical(renderers, scene, path):
    """No holdout, an empty one, one behind every splat, one out of view (those three run
    the plain programs) and a tiny triangle in view among the splats' depths that covers
    no pixel centre (the holdout programs run: map, depth test, batches) give the plain
    frame bit for bit, colour and Z; the scene's holdout does not."""
    r, cam = renderers[path], scene.camera
    c2w = np.linalg.inv(cam.world_to_camera)
    behind = scene.centre + 4.0 * scene.size * (scene.centre - cam.position) / np.linalg.norm(
        scene.centre - cam.position)
    side = c2w[:3, 0] * 3.0 * scene.size  # far to the right
    # a tenth of a pixel around the corner of four pixels, at the guitar's depth
    depth = 1.25 * scene.size
    corner = np.array([(80.0 - cam.cx) / cam.fx, (cam.cy - 48.0) / cam.fy, -1.0]) * depth
    tiny = corner + np.array([[0.05, 0.05, 0.0], [-0.05, 0.05, 0.0], [0.0, -0.05, 0.0]]) * depth / cam.fx
    tiny = Holdout((tiny @ c2w[:3, :3].T + c2w[:3, 3])[None])
    assert cam.near < depth_bounds(tiny, cam)[0] < 2 * scene.size
    assert np.isinf(holdout_depth(tiny, cam)).all()
    for early in (True, False):
        base = RenderOptions(early_termination=early)
        plain = r.render(scene.items, cam, base)
        for held in (None, Holdout(np.zeros((0, 3, 3))),
                     Holdout(scene.triangles["back_cube"] - scene.triangles["back_cube"].mean((0, 1)) + behind),
                     Holdout(scene.holdout.triangles + side), tiny):
            uploads = r.stats["holdout_uploads"]
            out = r.render(scene.items, cam, replace(base, holdout=held))
            # only the tiny triangle's map is drawn (its triangles sent once)
            assert r.stats["holdout_uploads"] - uploads == (held is tiny and early)
            np.testing.assert_array_equal(out.rgba, plain.rgba)
            np.testing.assert_array_equal(out.depth, plain.depth)
        assert not np.array_equal(r.render(scene.items, cam, replace(base, holdout=scene.holdout)).rgba,
                                  plain.rgba)
    assert np.isinf(depth_bounds(Holdout(scene.holdout.triangles + side), cam)[0])


def test_triangles_upload_once_per_key(scene):
    with OffscreenRenderer() as r:
        for kind in KINDS:  # every camera kind, the same triangles
            r.render(scene.items, camera_of(scene, kind), RenderOptions(holdout=scene.holdout))
        assert r.stats["holdout_uploads"] == 1
        same = Holdout(scene.holdout.triangles.copy())  # equal triangles: the same key
        r.render(scene.items, scene.camera, RenderOptions(holdout=same))
        assert r.stats["holdout_uploads"] == 1
        moved = Holdout(scene.holdout.triangles + 1e-3)
        r.render(scene.items, scene.camera, RenderOptions(holdout=moved))
        r.render(scene.items, scene.camera, RenderOptions(holdout=scene.holdout))
        assert r.stats["holdout_uploads"] == 2  # both resident


@pytest.mark.parametrize("path", PATHS)
def test_depth_of_field_and_motion_blur(renderers, scene, path):
    """Depth of field: the splats blurred as without a holdout, the surface seen through
    the pinhole (both as the reference). Motion blur (the engine's average of sub-frame
    renders): a surface moving across the guitar, averaged as the reference's."""
    r, cam = renderers[path], scene.camera
    dof = replace(cam, defocus=Defocus(0.02 * scene.size, 1.25 * scene.size))
    options = RenderOptions(holdout=scene.holdout)
    ref = reference.render(scene.items, dof, options)
    assert_matches(r.render(scene.items, dof, options), ref, reference.render(scene.items, dof))
    got, want = shutter.Average(2), shutter.Average(2)
    side = np.linalg.inv(cam.world_to_camera)[:3, 0] * 0.05 * scene.size
    for step in (0.0, 1.0):
        moved = RenderOptions(holdout=Holdout(scene.holdout.triangles + step * side))
        got.add(r.render(scene.items, cam, moved).rgba)
        want.add(reference.render(scene.items, cam, moved).rgba)
    assert psnr(got.result(), want.result()) >= MIN_PSNR


# ---- the depth test's precision: a splat just behind a surface is never kept ----

@pytest.mark.parametrize("path", PATHS)
def test_depth_test_keeps_exactly_the_fragments_in_front(renderers, path):
    """A tilted plane over the whole frame and a grid of small splats, each at a depth
    set against the map's own value h at its centre pixel: at h and one float32 step
    behind it they are dropped (never kept behind the surface), at held_band in front
    of it and farther they stay (the band is where rounding may drop a fragment in
    front); two far-apart splats beside the grid span the splats' depths."""
    r = renderers[path]
    cam = simple_camera(96, 64, 60.0, np.eye(4), near=0.1, far=100.0)  # at the origin, down -z
    plane = triangulate(*quad_mesh((0.0, 0.0, -2.0), (40.0, 0.0, 4.0), (0.0, 40.0, 0.0)))
    held = Holdout(plane)
    h = r.holdout_depth(held, cam)
    cols, rows = np.meshgrid(np.arange(6, 90, 8), np.arange(6, 60, 8))
    px, py = cols.ravel(), rows.ravel()
    n = px.size
    hz = h[py, px].astype(np.float64)
    zmin, zmax = 1.0, 3.5
    band = held_band(depth_encoding(zmin, zmax, *depth_bounds(held, cam)))
    assert 1e-7 < band < 2e-5
    offsets = np.array([0.0, 1.0, -1.01, -3.0, -1e4, 1e4])  # in bands (1.0: one float32 step)
    k = np.arange(n) % len(offsets)
    z = np.where(offsets[k] == 1.0, np.nextafter(hz.astype(np.float32), np.float32(np.inf)),
                 hz + offsets[k] * band).astype(np.float32).astype(np.float64)
    z = np.append(z, [zmin, zmax])
    u = np.append(px + 0.5, [2.0, 94.0])
    v = np.append(py + 0.5, [2.0, 62.0])
    pos = np.stack([(u - cam.cx) / cam.fx * z, (cam.cy - v) / cam.fy * z, -z], 1)
    s = SplatSet.allocate(n + 2, 0)
    s.positions[:] = pos
    s.scales[:] = 1e-4
    s.rotations[:] = (1.0, 0.0, 0.0, 0.0)
    s.opacities[:] = 0.9
    out = r.render([RenderItem(s)], cam, RenderOptions(holdout=held))
    alpha = out.rgba[py, px, 3]
    keep = offsets[k] < 0
    assert (alpha[keep] > 0.5).all() and (alpha[~keep] == 0).all()
    ref = reference.render([RenderItem(s)], cam, RenderOptions(holdout=held))
    far = np.abs(offsets[k]) >= 3.0
    np.testing.assert_array_equal(ref.rgba[py, px, 3][far] > 0.5, alpha[far] > 0.5)


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("kind", ["perspective", "equirect"])
def test_a_frame_drawn_in_tiles(renderers, scene, references, kind, path, monkeypatch):
    """Frames past MAX_TILE are drawn tile by tile, each with its own part of the surface
    map (the tile's offset in gl_holdout.vert/.frag) and depth buffer: with tiles of
    40 px, the frame drawn whole but for float32 rounding (early termination off, so the
    batches' stops do not depend on the tiles). On the compute path quads are also cut
    to the cells the surface leaves open, which differ tile by tile, and a cut quad
    rounds its interpolated offset differently (measured: 4.0e-4 at one pixel); a part
    of the map or of a footprint lost at a tile's edge would cost the alpha there."""
    from addon.gl import frame

    r, cam = renderers[path], camera_of(scene, kind)
    options = RenderOptions(holdout=scene.holdout, early_termination=False)
    whole = r.render(scene.items, cam, options)
    monkeypatch.setattr(frame, "MAX_TILE", 40)
    tiled = r.render(scene.items, cam, options)
    np.testing.assert_allclose(tiled.rgba, whole.rgba, atol=1e-3)
    ref, plain_ref = references(kind, early=False)
    assert_matches(tiled, ref, plain_ref)
