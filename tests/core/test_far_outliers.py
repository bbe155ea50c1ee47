"""core/far_outliers: a few far splats are found and left out; many are kept; real captures
lose nothing."""
import numpy as np
import pytest

from addon.core import far_outliers
from addon.core.framing import robust_bounds
from addon.core.formats import read


def _cloud(n=20_000, seed=3):
    return np.random.default_rng(seed).normal(size=(n, 3)).astype(np.float32)


def test_a_few_far_splats_are_left_out_and_the_rest_kept_in_order():
    pts = _cloud()
    far = np.array([[1e5, 0, 0], [0, -3e4, 0], [0, 0, 400.0], [np.nan, 0, 0]], np.float32)
    found = far_outliers.find(np.concatenate([pts[:100], far, pts[100:]]))
    assert (found.far, found.dropped) == (4, 4)
    expected = np.concatenate([np.arange(100), np.arange(104, len(pts) + 4)])
    np.testing.assert_array_equal(found.kept, expected)


def test_splats_within_reach_stay():
    pts = _cloud()
    radius = robust_bounds(pts).radius
    centre = robust_bounds(pts).centre
    inside = (centre + [0.9 * far_outliers.REACH * radius, 0, 0]).astype(np.float32)[None]
    found = far_outliers.find(np.concatenate([pts, inside]))
    assert found.kept is None and found.far == 0


def test_many_far_splats_are_not_thinned():
    pts = _cloud()
    sky = np.random.default_rng(1).normal(size=(int(far_outliers.MOST * len(pts)) + 5, 3)) * 1e4
    found = far_outliers.find(np.concatenate([pts, sky.astype(np.float32)]))
    assert found.kept is None and found.dropped == 0 and found.far == len(sky)


@pytest.mark.parametrize("name", ["guitar.ply", "test64.ply", "guitar.spz"])
def test_real_captures_lose_nothing(testdata, name):
    splats = read(testdata / name)
    assert far_outliers.find(splats.positions).kept is None


def test_empty_and_all_nan():
    assert far_outliers.find(np.zeros((0, 3), np.float32)).kept is None
    assert far_outliers.find(np.full((5, 3), np.nan, np.float32)).kept is None
