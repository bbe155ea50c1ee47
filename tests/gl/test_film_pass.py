"""The film pass (addon/gl/film.py, shaders/gl_film.frag): the offscreen renderer's frame in
the terms of Blender's render result, pinned to the engine's numpy conversion
(blender/render/film.result_rect) of the same frame.

Bar: the two run the same float32 steps in the same order, except the power of the sRGB
curve (GLSL's pow against numpy's), which may round a few ulp apart: 2e-6 relative is 16
ulp of float32, 1/500 of a 16-bit EXR's step. A wrong row order, a missed background or
world, or alpha left un-premultiplied moves values by orders of magnitude more.
"""
from __future__ import annotations

import numpy as np
import pytest

from addon.blender.render.film import result_rect
from addon.core.scene import Film, RenderItem, RenderOptions
from addon.gl import OffscreenRenderer, frame
from testing.gl_scenes import guitar_with_axes, random_splats, world_for

RTOL, ATOL = 2e-6, 1e-7
WORLD = (0.05, 0.2, 0.6)  # scene-linear
BACKGROUND = (0.1, 0.05, 0.2, 0.4)  # premultiplied display sRGB


def assert_film(out, under):
    want = result_rect(out.rgba, under)
    assert out.combined is not None and out.combined.shape == want.shape and out.combined.dtype == np.float32
    np.testing.assert_allclose(out.combined, want, rtol=RTOL, atol=ATOL)
    film = out.combined.reshape(out.rgba.shape)
    if under is None:  # alpha is the frame's, untouched, its rows turned over
        assert np.array_equal(film[..., 3], out.rgba[::-1, :, 3])
    else:
        assert np.all(film[..., 3] == 1.0)


@pytest.fixture(scope="module")
def guitar(testdata):
    """guitar.ply with its real axes, framed with empty pixels round it and partly covered
    ones at its edges: the alpha-0 and the soft cases of the conversion."""
    item, cam = guitar_with_axes(testdata)
    return [item], cam


@pytest.mark.parametrize("under", [None, WORLD, (0.0, 0.0, 0.0)], ids=["transparent", "world", "black"])
@pytest.mark.parametrize("background", [(0.0, 0.0, 0.0, 0.0), BACKGROUND], ids=["bare", "background"])
def test_film_is_the_engines_conversion_of_the_frame(renderer, guitar, under, background):
    items, cam = guitar
    plain = renderer.render(items, cam, RenderOptions(background=background))
    alpha = renderer.render(items, cam, RenderOptions()).rgba[..., 3]
    assert (alpha == 0).any() and ((alpha > 0.01) & (alpha < 0.99)).any() and (alpha > 0.99).any()
    out = renderer.render(items, cam, RenderOptions(film=Film(under), background=background))
    assert_film(out, under)
    # and the frame itself is the one drawn without a film
    assert plain.combined is None
    assert np.array_equal(plain.rgba, out.rgba) and np.array_equal(plain.depth, out.depth)


def test_film_of_a_tiled_frame_puts_each_tile_in_its_rows(renderer, guitar, monkeypatch):
    """Frames past MAX_TILE are drawn tile by tile: each tile's film lands where its rows
    are counted from the bottom. Tiles of 64 x 64 over a 320 x 240 frame: uneven ones at
    the right and top."""
    items, cam = guitar
    monkeypatch.setattr(frame, "MAX_TILE", 64)
    out = renderer.render(items, cam, RenderOptions(film=Film(WORLD)))
    assert_film(out, WORLD)


def test_film_on_the_gl33_path():
    """The GL 3.3 fallback (records in textures, CPU sort) makes the same film."""
    splats = random_splats(3000, 1, seed=8)
    item = RenderItem(splats, world=world_for(splats), key=("film33", 0))
    from addon.core.camera import look_at, simple_camera

    cam = simple_camera(96, 64, 50.0, look_at((0.0, -2.5, 0.3), (0.0, 0.0, 0.0)))
    with OffscreenRenderer(compute=False) as r:
        assert not r.uses_compute and r.has_film
        out = r.render([item], cam, RenderOptions(film=Film(WORLD), background=BACKGROUND))
    assert_film(out, WORLD)
