"""What each viewport display option shows, pixel by pixel (not just "it differs").

Drawn headless through the viewport's own path (viewport_scene.draw_offscreen: Blender's
gpu module into an RGBA32F GPUOffScreen) on the real captures with their real transform
(the RDF axes as a rotation on the object matrix), and predicted from core.preprocess:
- OPAQUE: every splat an opaque ellipse out to its extent (d^T conic d <= extent^2), so a
  pixel is covered (alpha exactly 1) where some drawn splat's ellipse holds its centre,
  else empty (alpha 0), and shows the colour of the nearest such splat, unblended.
- POINTS: every splat a square dot of half-size DrawSettings.point_size at its projected
  centre, opaque, in its own colour (the nearest dot wins).
- SH only: the view-dependent bands over grey, the DC term removed: the colour is
  0.5 + sum of the higher bands, which core.preprocess gives for the same splats with DC = 0.
The predictions start from the splats as the viewport stores them (half-float scales, DC,
higher SH and smallest-three quaternion: viewport/packing.py), so the comparison stays at
float32 precision and tests what each mode shows, not the storage's rounding.
Pixels whose prediction sits within the float32 error of a decision (an ellipse or square
edge, two splats at nearly the same depth) are left out of the exact comparison; they
are few, and counted.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from addon.core.formats import read
from addon.core.preprocess import project
from addon.core.scene import RenderItem
from testing.gl_scenes import framing_camera, world_for
from testing.viewport_scene import draw_offscreen

W, H = 160, 120
COLOUR_TOL = 1e-4   # float32 SH and grading against float64: ~1e-6; 8-bit steps are 4e-3
EDGE_TOL = 1e-3     # relative: an ellipse edge within this is a float32 coin toss


@pytest.fixture(scope="module", params=["test64.ply", "guitar.ply"])
def capture(request, testdata):
    s = read(testdata / request.param)
    if s.count > 2000:  # a real slice of guitar: every 200th splat keeps the frame readable
        s = s.subset(np.arange(0, s.count, 200))
    item = RenderItem(s, world=world_for(s), key=(request.param, 0))
    return item, framing_camera(item, W, H, distance=1.1)


def _as_stored(item):
    """The item with its splats rounded as the viewport's textures hold them."""
    from addon.blender.viewport.packing import halves, smallest_three

    s = item.splats
    three, largest = smallest_three(s.rotations)
    three = halves(three).astype(np.float64)
    q = np.empty((s.count, 4))
    others = np.array([[j for j in range(4) if j != i] for i in range(4)])
    q[np.arange(s.count)[:, None], others[largest]] = three
    q[np.arange(s.count), largest] = np.sqrt(np.clip(1.0 - (three ** 2).sum(1), 0.0, None))
    stored = replace(s, rotations=q.astype(np.float32), scales=halves(s.scales),
                     sh_dc=halves(s.sh_dc), sh_rest=halves(s.sh_rest))
    return replace(item, splats=stored)


def _display(**kw):
    from addon.blender.viewport import ItemDisplay

    return ItemDisplay(cull=False, key_bits=32, **kw)


def _pixels():
    ys, xs = np.mgrid[0:H, 0:W]
    return xs.ravel() + 0.5, ys.ravel() + 0.5


def _front(cover, ambiguous, depth):
    """Per pixel: index of the nearest covering splat (-1: none), and whether the pixel's
    outcome is uncertain (an edge within tolerance, or a near tie in depth)."""
    d = np.where(cover, depth[None], np.inf)
    front = np.where(cover.any(1), d.argmin(1), -1)
    srt = np.sort(d, axis=1)
    with np.errstate(invalid="ignore"):
        tie = np.isfinite(srt[:, 1]) & (srt[:, 1] - srt[:, 0] <= 1e-5 * np.abs(srt[:, 0]))
    # an uncertain splat in front of the winner could change it
    unsure = (ambiguous & (depth[None] <= np.where(front >= 0, srt[:, 0], np.inf)[:, None] + 1e-9)).any(1)
    return front, unsure | tie


def _check(img, front, unsure, rgb):
    img = img.reshape(-1, 4)
    sure = ~unsure
    assert sure.mean() > 0.97, f"{unsure.sum()} uncertain pixels"
    covered = front >= 0
    assert covered[sure].sum() > 0.05 * sure.sum(), "the scene must cover part of the frame"
    # coverage: alpha exactly 1 on covered pixels, 0 elsewhere; so the count matches too
    np.testing.assert_array_equal(img[sure, 3], covered[sure].astype(np.float32))
    assert (img[:, 3] == 1.0).sum() == covered.sum() - (covered & unsure).sum() + (img[unsure, 3] == 1).sum()
    # colour: the nearest splat's own, not blended with what lies behind it
    hit = sure & covered
    np.testing.assert_allclose(img[hit, :3], rgb[front[hit]], atol=COLOUR_TOL, rtol=0)


def _opaque_prediction(item, camera):
    p = project(_as_stored(item), camera)
    x, y = _pixels()
    dx = x[:, None] - p.means2d[None, :, 0]
    dy = y[:, None] - p.means2d[None, :, 1]
    A, B, C = p.conic.T
    m2 = A * dx * dx + 2 * B * dx * dy + C * dy * dy
    lim = p.extent ** 2
    drawn = p.valid[None]
    cover = drawn & (m2 <= lim)
    ambiguous = drawn & (np.abs(m2 - lim) <= EDGE_TOL * (lim + 1))
    return p, cover, ambiguous


def test_opaque_shows_each_ellipse_solid_in_its_own_colour(gpu_ready, capture):
    item, camera = capture
    img, _ = draw_offscreen([item], camera, [_display(mode="OPAQUE")])
    p, cover, ambiguous = _opaque_prediction(item, camera)
    front, unsure = _front(cover, ambiguous, p.depth)
    _check(img, front, unsure, p.rgb)
    assert set(np.unique(img[..., 3])) == {0.0, 1.0}


@pytest.mark.parametrize("size", [2.0, 3.5])
def test_points_are_dots_of_the_point_size_at_the_centres(gpu_ready, capture, size):
    from addon.blender.viewport.viewport_renderer import DrawSettings

    item, camera = capture
    img, _ = draw_offscreen([item], camera, [_display(mode="POINTS")], DrawSettings(point_size=size))
    p = project(_as_stored(item), camera)
    x, y = _pixels()
    dx = np.abs(x[:, None] - p.means2d[None, :, 0])
    dy = np.abs(y[:, None] - p.means2d[None, :, 1])
    # the viewport keeps splats core would cull for opacity or a degenerate covariance:
    # a dot needs only a finite centre in front of the camera
    drawn = (np.isfinite(p.means2d).all(1) & (p.depth > camera.near) & (p.depth <= camera.far))[None]
    cover = drawn & (dx <= size) & (dy <= size)
    ambiguous = drawn & (np.abs(np.maximum(dx, dy) - size) <= 1e-3)
    front, unsure = _front(cover, ambiguous, p.depth)
    _check(img, front, unsure, p.rgb)
    # each visible centre's own pixel is lit
    inside = drawn[0] & (p.means2d[:, 0] >= 0) & (p.means2d[:, 0] < W) & (p.means2d[:, 1] >= 0) \
        & (p.means2d[:, 1] < H)
    cx, cy = p.means2d[inside].astype(int).T
    assert inside.sum() >= 20 and (img[cy, cx, 3] == 1.0).all()


def test_sh_only_is_the_higher_bands_over_grey(gpu_ready, capture):
    """OPAQUE and SH only together: each pixel shows one splat's SH-only colour, unblended."""
    item, camera = capture
    img, _ = draw_offscreen([item], camera, [_display(mode="OPAQUE", sh_only=True)])
    p, cover, ambiguous = _opaque_prediction(item, camera)
    stored = _as_stored(item)
    no_dc = replace(stored, splats=replace(stored.splats, sh_dc=np.zeros_like(stored.splats.sh_dc)))
    want = project(no_dc, camera).rgb
    front, unsure = _front(cover, ambiguous, p.depth)
    _check(img, front, unsure, want)
    if item.splats.sh_degree == 0:  # no higher bands: plain grey
        np.testing.assert_array_equal(want, 0.5)
    else:  # the bands vary with the view and the colour lost its base
        assert np.ptp(want) > 0.2 and not np.allclose(want, p.rgb, atol=0.05)


def test_linear_output_decodes_each_splat_colour_as_colorspace_does(gpu_ready):
    """DrawSettings.linear_output converts each splat's colour before blending
    (splat_math's sl_srgb_decode): where one splat alone covers a pixel, the drawn
    straight colour is colorspace.srgb_to_linear of the sRGB drawing's, both sides of the
    knee and above 1."""
    from addon.blender.viewport import DrawSettings
    from addon.core.camera import look_at, simple_camera
    from addon.core.colorspace import srgb_to_linear
    from addon.core.sh import C0
    from addon.core.splats import SplatSet

    colours = np.array([[0.01, 0.03, 0.0404], [0.0405, 0.2, 0.5], [0.9, 1.0, 1.3]], np.float32)
    s = SplatSet.allocate(3, 0)
    s.positions[:] = [[-1.5, 0.0, 0.0], [0.0, 0.0, 0.0], [1.5, 0.0, 0.0]]
    s.scales[:] = 0.3
    s.rotations[:] = (1.0, 0.0, 0.0, 0.0)
    s.opacities[:] = 0.98
    s.sh_dc[:] = (colours - 0.5) / C0
    camera = simple_camera(96, 48, 60.0, look_at((0.0, -4.0, 0.0), (0.0, 0.0, 0.0)), near=0.1, far=20.0)
    items = [RenderItem(s)]
    srgb, _ = draw_offscreen(items, camera, settings=DrawSettings(linear_output=False))
    linear, _ = draw_offscreen(items, camera, settings=DrawSettings(linear_output=True))
    for x in (16, 48, 80):  # each splat's centre column
        row = int(np.argmax(srgb[:, x, 3]))
        a, b = srgb[row, x], linear[row, x]
        assert a[3] > 0.9 and a[3] == b[3]
        np.testing.assert_allclose(b[:3] / b[3], srgb_to_linear(a[:3] / a[3]), rtol=2e-6, atol=1e-7)
