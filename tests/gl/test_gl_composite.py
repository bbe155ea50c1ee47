"""Front-to-back batched compositing (addon/gl/composite.py): early termination and the
Z pass, against the float64 reference (core/reference.py).

Bars: the PSNR bar of test_gl_render.py (60 dB, reasons there). Early termination has a
bound of its own: the GL renderer stops a pixel at the end of the batch in which its
transmittance T fell below 1e-4, so against its own full composite it may only miss the
light behind that point: at most T * (largest colour or alpha) < 1e-4 per channel.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from addon.core import reference
from addon.core.camera import simple_camera
from addon.core.scene import RenderItem, RenderOptions
from addon.core.splats import SplatSet
from addon.gl import OffscreenRenderer, composite, frame
from addon.gl.software import is_software
from testing.gl_scenes import assert_depth_matches, framing_camera, guitar_with_axes, psnr

MIN_PSNR = 60.0
C0 = 0.28209479177387814


def layers(count: int = 12, per_side=(64, 48), opacity: float = 0.95, seed: int = 0):
    """`count` walls of round splats facing the camera at depths 2, 2.25, 2.5, ... (one
    per layer a colour), each wall a jittered grid covering the whole frame: every pixel
    sees every layer and saturates (T < 1e-4) after four of them, except in a band on the
    left (the first ~19 columns of layers_camera) where the splats' opacity is 0.05 and
    all layers together leave T ~ 0.1."""
    rng = np.random.default_rng(seed)
    nx, ny = per_side
    n = count * nx * ny
    s = SplatSet.allocate(n, 0)
    k = np.repeat(np.arange(count), nx * ny)
    gx, gy = np.meshgrid(np.linspace(-1.2, 1.2, nx), np.linspace(-0.9, 0.9, ny))
    depth = 2.0 + 0.25 * k
    s.positions[:, 0] = np.tile(gx.ravel(), count) * depth / 2.0 + rng.normal(0, 0.004, n)
    s.positions[:, 1] = np.tile(gy.ravel(), count) * depth / 2.0 + rng.normal(0, 0.004, n)
    s.positions[:, 2] = -depth
    s.scales[:] = (0.03 * depth / 2.0)[:, None]
    s.rotations[:] = (1.0, 0.0, 0.0, 0.0)
    s.opacities[:] = np.where(np.tile(gx.ravel(), count) < -0.7, 0.05, opacity)
    hues = rng.uniform(0.1, 0.9, (count, 3))
    s.sh_dc[:] = (hues[k] - 0.5) / C0
    return RenderItem(s, key=("layers", count, seed))


def layers_camera(width=96, height=72):
    return simple_camera(width, height, 60.0, np.eye(4), near=0.1, far=100.0)


def assert_early_termination_bound(stop, full, trimmed: bool):
    """A pixel stopped early differs from the full composite by at most the 1e-4 of light
    left behind it. Where the saturation map trims quads to their unsaturated cells
    (trimmed), a trimmed quad's corners move, and with them the float32 rounding of the
    offset interpolated across it: a fragment whose alpha lies within that rounding of the
    1/255 cut may fall on the other side of it, moving its pixel by up to T/255 (a "cut
    event": 1 pixel in these test frames, 5 of the bench frame's 2 million, where such a
    splat's alpha was 0.003920 against the cut's 0.0039216). Those are allowed, no more
    than 1 pixel in 1,000 and each within 1/255 past the bound; a real leak (a splat left
    out over unsaturated pixels) moves pixels by its full alpha, and many of them."""
    diff = np.abs(stop.rgba.astype(np.float64) - full.rgba).max(axis=-1)
    bound = 1e-4 * max(1.0, float(full.rgba.max()))
    events = diff > bound
    if not trimmed:
        assert not events.any()
    assert events.mean() <= 1e-3
    assert diff.max() <= bound + 1.0 / 255.0


@pytest.fixture(scope="module")
def fallback():
    r = OffscreenRenderer(compute=False)  # GL 3.3: no saturation map, the depth marks alone
    yield r
    r.close()


@pytest.mark.parametrize("path", ["renderer", "fallback"])
def test_batched_early_termination_stays_within_its_bound(path, request):
    renderer = request.getfixturevalue(path)
    item, cam = layers(), layers_camera()
    stop = renderer.render([item], cam, RenderOptions(early_termination=True))
    stats = dict(renderer.stats)
    full = renderer.render([item], cam, RenderOptions(early_termination=False))
    assert renderer.stats["splat_draws"] - stats["splat_draws"] == 1  # one batch, no marks
    assert renderer.stats["saturation_passes"] == stats["saturation_passes"]
    # most pixels saturate, the batches and marks ran, and the stop changed the image
    saturated = full.rgba[..., 3] > 1 - 1e-4
    assert 0.6 < saturated.mean() < 0.9 and not saturated[:, :12].any()
    assert stats["splat_draws"] > 2 and stats["saturation_passes"] == stats["splat_draws"] - 1
    assert np.abs(stop.rgba.astype(np.float64) - full.rgba).max() > 0
    assert_early_termination_bound(stop, full, trimmed=path == "renderer")


def test_early_termination_bound_on_a_real_capture(renderer, testdata):
    """guitar.ply with its real (RDF) axes, 320x240: the map's culling and trimming keep
    the frame within the early-termination bound of the full composite."""
    item, cam = guitar_with_axes(testdata)
    before = dict(renderer.stats)
    stop = renderer.render([item], cam, RenderOptions(early_termination=True))
    assert renderer.stats["saturation_passes"] > before["saturation_passes"]
    full = renderer.render([item], cam, RenderOptions(early_termination=False))
    assert (full.rgba[..., 3] > 1 - 1e-4).mean() > 0.05  # some pixels do stop early
    assert np.abs(stop.rgba.astype(np.float64) - full.rgba).max() > 0
    assert_early_termination_bound(stop, full, trimmed=True)


def test_early_termination_against_both_references(renderer):
    """Within the 60 dB bar of the reference with early termination (INRIA's stop) and of
    the one without it (the full composite)."""
    item, cam = layers(), layers_camera()
    out = renderer.render([item], cam, RenderOptions())
    assert RenderOptions().early_termination  # the default
    for early in (True, False):
        ref = reference.render([item], cam, RenderOptions(early_termination=early))
        assert psnr(out.rgba, ref.rgba) >= MIN_PSNR
    assert_depth_matches(out, [item], cam, RenderOptions())


@pytest.mark.parametrize("early", [True, False])
def test_z_pass_on_layered_surfaces(renderer, early):
    """Known layers: the depth is the T alpha weighted mean of the layer depths, which
    for four opaque-ish layers in front is close to the first's and past it."""
    item, cam = layers(), layers_camera()
    options = RenderOptions(early_termination=early)
    out = renderer.render([item], cam, options)
    assert_depth_matches(out, [item], cam, options)
    centre = out.depth[20:52, 30:66]
    weights = 0.95 * 0.05 ** np.arange(12)  # one full layer after another, roughly
    expect = weights @ (2.0 + 0.25 * np.arange(12)) / weights.sum()
    assert np.isfinite(centre).all()
    np.testing.assert_allclose(np.median(centre), expect, rtol=0.01)


def test_z_pass_on_a_real_capture_crop(renderer, testdata):
    """guitar.ply with its real (RDF) axes: the Z pass on a 160x120 frame, the reference
    on a 56x48 window of it (the same projection, exactly)."""
    item, _ = guitar_with_axes(testdata)
    cam = framing_camera(item, 160, 120, distance=1.1)
    out = renderer.render([item], cam, RenderOptions())
    x, y, w, h = 52, 36, 56, 48
    crop_out = type(out)(out.rgba[y:y + h, x:x + w], out.depth[y:y + h, x:x + w])
    assert_depth_matches(crop_out, [item], cam, RenderOptions(), window=(x, y, w, h))


def test_z_pass_costs_no_extra_draws():
    """The depth comes from the colour draws' second attachment: the same number of splat
    draws and saturation passes with the Z pass as without it."""
    item, cam = layers(), layers_camera()
    counts = {}
    for want in (False, True):
        with OffscreenRenderer(depth_pass=want) as r:
            out = r.render([item], cam, RenderOptions())
            counts[want] = (r.stats["splat_draws"], r.stats["saturation_passes"])
            assert np.isfinite(out.depth).any() == want
    assert counts[True] == counts[False] and counts[True][0] > 1


@pytest.mark.parametrize("scene", ["layers", "guitar"])
def test_a_software_gl_draws_each_batch_in_flushed_chunks_with_the_same_pixels(scene, testdata,
                                                                                monkeypatch):
    """On a CPU rasteriser each batch goes out in draws of FIRST_CHUNK splats doubling up
    to DRAW_CHUNK, with a glFlush after each (so that llvmpipe rasterises one chunk while
    it bins the next); the order of the splats is unchanged, so colour and depth are the
    same bit for bit. A GPU draws each batch in one call and never flushes."""
    item, cam = (layers(), layers_camera()) if scene == "layers" else guitar_with_axes(testdata)
    with OffscreenRenderer() as r:
        software = is_software(r.gl_info["GL_RENDERER"])
        monkeypatch.setattr(composite, "FIRST_CHUNK", 10**9)
        monkeypatch.setattr(composite, "DRAW_CHUNK", 10**9)
        whole = r.render([item], cam, RenderOptions())
        before = dict(r.stats)
        monkeypatch.setattr(composite, "FIRST_CHUNK", 97)
        monkeypatch.setattr(composite, "DRAW_CHUNK", 4 * 97)
        chunked = r.render([item], cam, RenderOptions())
        visible = len(r.last_order())
        batches = r.stats["splat_draws"] - before["splat_draws"]
        flushes = r.stats["draw_flushes"] - before["draw_flushes"]
    assert batches == before["splat_draws"] > 2
    if software:
        assert before["draw_flushes"] == batches  # one chunk a batch
        sizes = [count for _, count in composite.batches(visible, True)]
        assert flushes == sum(ramped_chunks(n, 97, 4 * 97) for n in sizes) > 10 * batches
    else:
        assert flushes == before["draw_flushes"] == 0
    np.testing.assert_array_equal(chunked.rgba, whole.rgba)
    np.testing.assert_array_equal(chunked.depth, whole.depth)


def ramped_chunks(count: int, first: int, most: int) -> int:
    """Draws for a batch of count splats in chunks of first, 2 first, ... up to most."""
    draws, step = 0, first
    while count > 0:
        count -= step
        draws += 1
        step = min(2 * step, most)
    return draws


def test_background_goes_behind_after_compositing(renderer):
    item, cam = layers(count=2, opacity=0.4), layers_camera(48, 36)
    bg = (0.1, 0.2, 0.3, 0.5)
    out = renderer.render([item], cam, RenderOptions(background=bg))
    ref = reference.render([item], cam, RenderOptions(background=bg))
    assert psnr(out.rgba, ref.rgba) >= MIN_PSNR
    plain = renderer.render([item], cam, RenderOptions())
    t = 1.0 - plain.rgba[..., 3:4]
    np.testing.assert_allclose(out.rgba, plain.rgba + t * np.float32(bg), atol=1e-6)
    assert_depth_matches(out, [item], cam, replace(RenderOptions(), background=bg))


def needles(n: int, seed: int, spread, longest: float, thinnest: float, max_opacity: float):
    """n needles and discs at random angles around (0, 0, -3): long axis 0.02 m to
    `longest`, the other e^-thinnest to 1 times it, opacity 0.05 to max_opacity."""
    rng = np.random.default_rng(seed)
    s = SplatSet.allocate(n, 0)
    s.positions[:] = rng.uniform(-0.8, 0.8, (n, 3)) * spread + (0.0, 0.0, -3.0)
    long_axis = np.exp(rng.uniform(np.log(0.02), np.log(longest), n))
    s.scales[:] = np.column_stack([long_axis, long_axis * np.exp(rng.uniform(-thinnest, 0, n)),
                                   np.full(n, 1e-4)])
    q = rng.normal(size=(n, 4))
    s.rotations[:] = q / np.linalg.norm(q, axis=1, keepdims=True)
    s.opacities[:] = rng.uniform(0.05, max_opacity, n)
    s.sh_dc[:] = rng.normal(0.0, 1.0, (n, 3))
    return RenderItem(s, key=("needles", n, seed, longest))


def test_tight_quads_keep_the_footprint_of_needles(renderer):
    """Quads fitted to each splat's 1/255 ellipse (gl_splat.vert) light the same pixels as
    the reference's square ones, for needles and discs at every angle: a pixel lit by one
    renderer only must sit at the 1/255 cut (alpha within float32 rounding of it)."""
    item, cam = needles(400, 7, (1.0, 0.6, 0.3), 0.4, 6, 1.0), layers_camera(128, 96)
    options = RenderOptions(early_termination=False)
    out = renderer.render([item], cam, options).rgba[..., 3]
    ref = reference.render([item], cam, options).rgba[..., 3]
    assert (ref > 0).mean() > 0.3
    only = (out > 0) != (ref > 0)
    assert np.maximum(out, ref)[only].max(initial=0.0) < 1.01 / 255


def test_a_frame_drawn_in_tiles_is_the_frame_drawn_whole(renderer, monkeypatch):
    """Frames wider than MAX_TILE are drawn tile by tile, and each quad is kept inside its
    tile (gl_splat.vert): a splat across a tile's edge is drawn, cut, in every tile it
    reaches. With tiles of 40 px, needles and large discs across their edges give the
    same pixels as the whole frame, but for the float32 rounding of the interpolated
    whitened offset, which depends on the quad (measured: 6.7e-5 at one pixel); a part of
    a footprint lost at a tile's edge would be off by its alpha, > 1/255."""
    item, cam = needles(300, 3, (1.2, 0.8, 0.3), 1.5, 5, 0.9), layers_camera(150, 100)
    options = RenderOptions(early_termination=False)
    whole = renderer.render([item], cam, options)
    monkeypatch.setattr(frame, "MAX_TILE", 40)
    tiled = renderer.render([item], cam, options)
    assert (whole.rgba[..., 3] > 0.01).mean() > 0.5
    np.testing.assert_allclose(tiled.rgba, whole.rgba, atol=2e-4)
    ref = reference.render([item], cam, options)
    assert psnr(tiled.rgba, ref.rgba) >= MIN_PSNR


def tilted_needles(depth: float = 6.0, count: int = 8):
    """Needles behind layers()'s walls, tilted 45 degrees, centred at column ~32 of
    layers_camera() (saturated there) with their 1/255 tips reaching column ~11, inside
    the unsaturated band on the left: only their tips' pixels need drawing."""
    s = SplatSet.allocate(count, 0)
    f = 48.0 / np.tan(np.radians(30.0))  # layers_camera's focal length in pixels
    rows = np.linspace(12.0, 60.0, count)
    s.positions[:] = np.column_stack([np.full(count, (32.0 - 48.0) * depth / f),
                                      (36.0 - rows) * depth / f, np.full(count, -depth)])
    sigma = 30.0 / np.sqrt(2.0 * np.log(255 * 0.9)) * depth / f  # 1/255 cut at 30 px
    s.scales[:] = (sigma, 0.02 * sigma, 1e-4)
    half = np.radians(45.0) / 2.0
    s.rotations[:] = (np.cos(half), 0.0, 0.0, np.sin(half))
    s.opacities[:] = 0.9
    s.sh_dc[:] = (np.array([0.9, 0.2, 0.1]) - 0.5) / C0
    return RenderItem(s, key=("tilted needles", depth, count))


def test_saturation_culling_keeps_tips_that_reach_unsaturated_pixels(renderer):
    """The vertex stage drops a splat when every pixel in its footprint's box is saturated;
    tilted needles lying mostly over saturated pixels, with only their tips in the
    unsaturated band, must still be drawn there (a box smaller than their alpha >= 1/255
    ellipse's would drop them whole)."""
    walls, cam = layers(), layers_camera()
    items = [walls, tilted_needles()]
    out = renderer.render(items, cam, RenderOptions())
    assert renderer.stats["saturation_passes"] > 0
    full = renderer.render(items, cam, RenderOptions(early_termination=False))
    without = renderer.render([walls], cam, RenderOptions(early_termination=False))
    band = (slice(None), slice(0, 18))  # columns 0-17 never saturate
    assert np.abs(full.rgba[band] - without.rgba[band]).max() > 1e-3  # tips: 10x the ET bound
    assert_early_termination_bound(out, full, trimmed=True)

