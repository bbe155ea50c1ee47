"""sRGB <-> linear (core/colorspace.py): the IEC 61966-2-1 curves."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.colorspace import linear_to_srgb, premultiplied_srgb_to_linear, srgb_to_linear


def test_known_values():
    # Hand values: 0.5 sRGB = ((0.555)/1.055)^2.4; the knee 0.04045 -> 0.04045/12.92.
    assert srgb_to_linear(0.5) == pytest.approx(((0.5 + 0.055) / 1.055) ** 2.4, rel=1e-15)
    assert srgb_to_linear(0.04045) == pytest.approx(0.04045 / 12.92, rel=1e-15)
    assert srgb_to_linear(1.0) == pytest.approx(1.0, rel=1e-15)
    assert srgb_to_linear(0.0) == 0.0
    assert linear_to_srgb(0.18) == pytest.approx(1.055 * 0.18 ** (1 / 2.4) - 0.055, rel=1e-15)


def test_round_trip_and_continuity():
    x = np.linspace(-0.5, 4.0, 10001)
    back = linear_to_srgb(srgb_to_linear(x))
    # The standard's knees (0.04045 and 0.0031308) disagree by 5e-9 in linear terms,
    # so sRGB values within ~1e-7 below 0.04045 come back off by up to 3e-8.
    knee = np.abs(np.abs(x) - 0.04045) < 1e-7
    assert knee.any()
    np.testing.assert_allclose(back[~knee], x[~knee], atol=1e-13)
    np.testing.assert_allclose(back[knee], x[knee], atol=1e-7)
    # The two pieces meet at the knee to within the standard's rounding of 0.04045.
    lo, hi = srgb_to_linear(0.04045 - 1e-12), srgb_to_linear(0.04045 + 1e-12)
    assert abs(hi - lo) < 1e-7


def test_premultiplied():
    rgba = np.array([[0.25, 0.1, 0.0, 0.5], [0.3, 0.2, 0.1, 0.0]], np.float32)
    out = premultiplied_srgb_to_linear(rgba)
    assert out.dtype == np.float32
    np.testing.assert_allclose(out[0, :3], srgb_to_linear(rgba[0, :3] / 0.5) * 0.5, rtol=1e-6)
    assert np.all(out[1] == 0.0)  # uncovered: nothing to convert, as the render result holds it
    assert out[0, 3] == 0.5
