"""film.result_rect, the engine's block-by-block path from a renderer's frame to the Combined
pass, pinned bit for bit to the whole-frame numpy steps it replaced:
bottom_up(composite_over(premultiplied_srgb_to_linear(rgba), world))."""
from __future__ import annotations

import numpy as np
import pytest

from addon.blender.render import film
from addon.blender.render.film import bottom_up, result_rect
from addon.core.colorspace import composite_over, premultiplied_srgb_to_linear


def reference(rgba, world, srgb):
    linear = premultiplied_srgb_to_linear(rgba) if srgb else np.asarray(rgba, np.float32)
    return bottom_up(composite_over(linear, world) if world is not None else linear)


def frame(h, w, seed):
    """Premultiplied frames as renderers give them: empty, faint, opaque pixels, colours on
    both sides of the curve's knee and above 1."""
    rng = np.random.default_rng(seed)
    alpha = rng.choice([0.0, 1.0, 0.5, 1e-6], (h, w, 1)).astype(np.float32)
    alpha = np.where(rng.random((h, w, 1)) < 0.5, rng.random((h, w, 1)), alpha).astype(np.float32)
    colour = rng.choice([0.0, 0.01, 0.04045, 0.5, 1.0, 1.7], (h, w, 3))
    colour = np.where(rng.random((h, w, 3)) < 0.5, rng.uniform(0, 1.5, (h, w, 3)), colour)
    return np.concatenate([colour * alpha, alpha], axis=2).astype(np.float32)


def test_colour_where_alpha_is_zero_still_gives_zeros():
    """A renderer's background (gl/frame.behind) leaves colour where alpha is 0: the
    whole-frame steps give 0 there, and so does the divide by +inf."""
    rgba = frame(33, 40, seed=5)
    empty = rgba[..., 3] == 0
    assert empty.any()
    rgba[empty, :3] = np.float32([0.2, 1.3, 0.0])
    for world in (None, (0.05, 0.2, 0.9)):
        same_bits(result_rect(rgba, world), reference(rgba, world, True))
    assert np.all(result_rect(rgba, None).reshape(rgba.shape)[::-1][empty] == 0)


def same_bits(a, b):
    assert a.dtype == b.dtype == np.float32 and a.shape == b.shape
    np.testing.assert_array_equal(a.view(np.uint32), b.view(np.uint32))


@pytest.mark.parametrize("world", [None, (0.0, 0.0, 0.0), (0.05, 0.2, 0.9), (1.5, 0.0, 0.3)])
@pytest.mark.parametrize("srgb", [True, False])
@pytest.mark.parametrize("shape", [(1, 1), (7, 5), (97, 131), (270, 480)])
def test_result_rect_is_the_whole_frame_steps_bit_for_bit(shape, srgb, world):
    rgba = frame(*shape, seed=shape[0] * 1000 + shape[1])
    same_bits(result_rect(rgba, world, srgb=srgb), reference(rgba, world, srgb))


@pytest.mark.parametrize("block", [1, 4 * 13, 4 * 131 * 3 + 8, 1 << 20])
def test_block_size_does_not_change_a_bit(monkeypatch, block):
    """Blocks of one row, of part of a row (one row each), of rows plus a remainder, or
    the whole frame at once give the same pixels."""
    rgba = frame(97, 131, seed=3)
    monkeypatch.setattr(film, "BLOCK_VALUES", block)
    same_bits(result_rect(rgba, (0.05, 0.2, 0.9)), reference(rgba, (0.05, 0.2, 0.9), True))
    same_bits(result_rect(rgba, None), reference(rgba, None, True))


def test_result_rect_of_a_real_capture_render_is_bit_for_bit(testdata):
    """A frame of the guitar capture from the reference renderer (its real axes), not a
    multiple of the block's rows."""
    from addon.core import formats
    from addon.core.axes import matrix_for
    from addon.core.camera import look_at, simple_camera
    from addon.core.reference import render
    from addon.core.scene import RenderItem, RenderOptions

    sp = formats.read(testdata / "guitar.ply")
    sp = sp.subset(np.arange(0, sp.count, 40))
    world = np.eye(4)
    world[:3, :3] = matrix_for(sp.axes)
    pts = sp.positions.astype(np.float64) @ world[:3, :3].T
    centre = np.median(pts, axis=0)
    cam = simple_camera(150, 90, 50.0, look_at(centre + np.array([0.0, -2.5, 0.4]), centre))
    rgba = render([RenderItem(sp, world=world)], cam, RenderOptions()).rgba
    assert 0.05 < (rgba[..., 3] > 0.05).mean() < 0.95  # splats and empty background both
    for world_rgb in (None, (0.05, 0.2, 0.9)):
        same_bits(result_rect(rgba, world_rgb), reference(rgba, world_rgb, True))
