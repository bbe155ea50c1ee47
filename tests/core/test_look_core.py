"""Object look: colour matrix and crop weights (pure numpy)."""
from __future__ import annotations

import math

import numpy as np

from addon.core.look import (LUMA, CropBox, CropSphere, apply_crop, color_matrix, crop_weights,
                             hue_matrix)
from addon.core.splats import SplatSet

EXACT = 1e-12  # float64 matrix products of order-1 values


def test_identity_and_exposure_and_tint():
    from addon.core.scene import IDENTITY_COLOR

    # the default look is exactly the identity, so consumers can skip the matrix bit-exactly
    assert np.array_equal(color_matrix(), IDENTITY_COLOR)
    m = color_matrix()
    m[0, 0] = 5.0  # callers get their own copy
    assert np.array_equal(color_matrix(), IDENTITY_COLOR)
    m = color_matrix(tint=(1.0, 0.5, 0.25), exposure=1.0)
    np.testing.assert_allclose(m[:, :3], np.diag([2.0, 1.0, 0.5]), atol=EXACT)
    assert m.shape == (3, 4) and not m[:, 3].any()


def test_saturation_keeps_luma_and_zero_gives_grey():
    c = np.array([0.9, 0.3, 0.1])
    grey = color_matrix(saturation=0.0)[:, :3] @ c
    np.testing.assert_allclose(grey, np.full(3, LUMA @ c), atol=EXACT)
    boosted = color_matrix(saturation=2.0)[:, :3] @ c
    np.testing.assert_allclose(LUMA @ boosted, LUMA @ c, atol=EXACT)
    np.testing.assert_allclose(boosted - LUMA @ c, 2 * (c - LUMA @ c), atol=EXACT)


def test_hue_is_a_luma_preserving_rotation_group():
    c = np.array([0.9, 0.3, 0.1])
    for angle in (0.3, 1.0, 2.5):
        h = hue_matrix(angle)
        np.testing.assert_allclose(LUMA @ (h @ c), LUMA @ c, atol=EXACT)
        np.testing.assert_allclose(h @ np.ones(3), np.ones(3), atol=EXACT)  # grey unchanged
    np.testing.assert_allclose(hue_matrix(0.4) @ hue_matrix(0.7), hue_matrix(1.1), atol=EXACT)
    np.testing.assert_allclose(hue_matrix(2 * math.pi), np.eye(3), atol=EXACT)
    red = hue_matrix(math.radians(120)) @ np.array([1.0, 0, 0])
    assert red[1] > red[0] and red[1] > red[2]  # +120 degrees turns red towards green


def test_crop_box_sphere_softness_and_invert():
    pos = np.array([[0, 0, 0], [0.9, 0, 0], [1.5, 0, 0], [0, 0, 3]], np.float32)
    box = CropBox(center=(0, 0, 0), size=(2, 2, 2))
    np.testing.assert_array_equal(crop_weights(pos, box=box), [1, 1, 0, 0])
    inv = CropBox(size=(2, 2, 2), invert=True)
    np.testing.assert_array_equal(crop_weights(pos, box=inv), [0, 0, 1, 1])
    soft = crop_weights(pos, box=CropBox(size=(2, 2, 2), softness=0.2))
    # depth inside = 0.1 for x=0.9 -> s = 0.5 -> smoothstep 0.5
    np.testing.assert_allclose(soft, [1, 0.5, 0, 0], atol=1e-6)
    sphere = CropSphere(center=(0, 0, 2), radius=1.5)
    np.testing.assert_array_equal(crop_weights(pos, sphere=sphere), [0, 0, 0, 1])
    both = crop_weights(pos, box=box, sphere=CropSphere(radius=1.0))
    np.testing.assert_array_equal(both, [1, 1, 0, 0])
    assert crop_weights(pos) is None


def test_apply_crop_shares_positions():
    s = SplatSet.allocate(3)
    s.positions[:, 0] = [0, 2, 5]
    out = apply_crop(s, sphere=CropSphere(radius=1.0))
    assert out.positions is s.positions
    np.testing.assert_array_equal(out.opacities, [1, 0, 0])
    assert apply_crop(s) is s
