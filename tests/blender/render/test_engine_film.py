"""The engine's pixel conversions (no bpy): sRGB -> scene-linear, world, flips, border."""
from __future__ import annotations

import numpy as np
import pytest

from addon.blender.render.film import (BACKGROUND_DEPTH, Region, blender_depth, bottom_up,
                                       region_camera, render_region)
from addon.core.colorspace import composite_over, srgb_to_linear
from addon.core.colorspace import premultiplied_srgb_to_linear as to_scene_linear
from addon.core.camera import look_at, simple_camera


def test_scene_linear_unpremultiplies_before_the_curve():
    rng = np.random.default_rng(1)
    # Both segments of the curve, and SH colours above 1 (clamped only at 0).
    straight = rng.uniform(0, 1.5, (500, 3))
    alpha = rng.uniform(0.01, 1, (500, 1))
    out = to_scene_linear(np.concatenate([straight * alpha, alpha], axis=1))
    assert out.dtype == np.float32
    # float32 curve against the float64 one: a divide, powf and two multiplies, each
    # within an ulp (1.2e-7 relative): 1e-6 allows 8 ulps.
    np.testing.assert_allclose(out[:, :3], srgb_to_linear(straight) * alpha, rtol=1e-6, atol=1e-9)
    np.testing.assert_array_equal(out[:, 3], alpha[:, 0].astype(np.float32))


def test_alpha_zero_stays_zero():
    rgba = np.zeros((2, 2, 4), np.float32)
    out = to_scene_linear(rgba)
    assert np.all(out == 0)


def test_world_goes_under_premultiplied_colour():
    rgba = np.array([[[0.2, 0.1, 0.0, 0.5], [0.0, 0.0, 0.0, 0.0]]], np.float32)
    out = composite_over(rgba, (0.4, 0.6, 0.8))
    np.testing.assert_allclose(out[0, 0], [0.2 + 0.5 * 0.4, 0.1 + 0.5 * 0.6, 0.5 * 0.8, 1.0], rtol=1e-6)
    np.testing.assert_allclose(out[0, 1], [0.4, 0.6, 0.8, 1.0], rtol=1e-6)


def test_depth_background_and_flip():
    depth = np.array([[1.0, np.inf], [2.0, 3.0]], np.float32)
    flat = bottom_up(blender_depth(depth))
    np.testing.assert_array_equal(flat, [2.0, 3.0, 1.0, BACKGROUND_DEPTH])


def test_border_region_truncates_like_blender():
    # 0.1 * 50 = 5, 0.55 * 50 = 27.5 -> 27; 0.2 * 40 = 8, 0.9 * 40 = 36 (Blender gave 22x28 here).
    assert render_region(50, 40, True, (0.1, 0.55, 0.2, 0.9)) == Region(5, 8, 22, 28)
    assert render_region(50, 40, False, (0.1, 0.55, 0.2, 0.9)) == Region(0, 0, 50, 40)


@pytest.mark.parametrize("ortho", [False, True])
def test_region_camera_projects_like_a_crop_of_the_full_frame(ortho):
    from dataclasses import replace

    full = replace(simple_camera(64, 48, 40.0, look_at((0.3, -5, 0.2), (0, 0, 0))), ortho=ortho)
    region = Region(10, 5, 20, 30)  # x from the left, y from the bottom
    crop = region_camera(full, region)
    points = np.random.default_rng(2).uniform(-1, 1, (20, 3))
    a, b = full.project(points), crop.project(points)
    top = full.height - (region.y + region.height)
    np.testing.assert_allclose(b[:, 0], a[:, 0] - region.x, atol=1e-12)
    np.testing.assert_allclose(b[:, 1], a[:, 1] - top, atol=1e-12)
    assert (crop.width, crop.height) == (20, 30)
