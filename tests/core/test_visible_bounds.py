"""The box of the splats that show (core/visible_bounds.py): a faint, sparse halo round the
subject is left out, a capture without one keeps the box of every centre."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core import formats, framing
from addon.core.axes import matrix_for
from addon.core.splats import SplatSet
from addon.core.visible_bounds import visible_bounds
from testing.framing_captures import haloed_capture

SUBJECT = 40000  # haloed_capture's subject splats come first


def _world(splats):
    return splats.positions.astype(np.float64) @ matrix_for(splats.axes).T


@pytest.mark.parametrize("halo", [2600, 15000])
def test_a_faint_halo_5x_the_subject_is_left_out(halo):
    """The subject's own percentile box, to 2% of its size, whether the halo moves the box
    of every centre to twice the subject (2600 halo splats) or six times (15000)."""
    splats = haloed_capture(halo=halo)
    points = _world(splats)
    subject = framing.robust_bounds(points[:SUBJECT])
    every = framing.robust_bounds(points)
    shown = visible_bounds(points, splats.opacities, splats.scales)
    print(f"halo {halo}: box of every centre {every.size / subject.size:.2f}x the subject's, "
          f"of those shown {shown.size / subject.size:.3f}x")
    assert every.size > 1.8 * subject.size  # the old box: the test can fail
    np.testing.assert_allclose(shown.low, subject.low, atol=0.02 * subject.size)
    np.testing.assert_allclose(shown.high, subject.high, atol=0.02 * subject.size)


def test_the_halo_shows_once_it_is_opaque():
    """The denser halo (15000 splats) made opaque adds up along a line of sight, as it does
    in the frame: part of what shows, its box is the wide one."""
    splats = haloed_capture(halo=15000)
    points = _world(splats)
    every = framing.robust_bounds(points)
    assert visible_bounds(points, splats.opacities, splats.scales).size < 0.3 * every.size  # faint
    splats.opacities[SUBJECT:] = 1.0
    assert visible_bounds(points, splats.opacities, splats.scales).size > 0.95 * every.size


@pytest.mark.parametrize("name", ["guitar.ply", "test64.ply"])
def test_real_captures_keep_their_box(testdata, name):
    """guitar.ply (a third of its splats below opacity 0.1, inside the guitar) and test64.ply
    (64 large, overlapping splats, a third of them faint): the box of every centre, to 0.5%
    of its size."""
    splats = formats.read(testdata / name)
    points = _world(splats)
    every = framing.robust_bounds(points)
    shown = visible_bounds(points, splats.opacities, splats.scales)
    np.testing.assert_allclose(shown.low, every.low, atol=0.005 * every.size)
    np.testing.assert_allclose(shown.high, every.high, atol=0.005 * every.size)


def test_nothing_solid_falls_back_to_every_centre():
    """A capture of sparse faint splats alone: none shows, so every centre counts."""
    rng = np.random.default_rng(3)
    splats = SplatSet.allocate(3000, 0)
    splats.positions[:] = rng.normal(size=(3000, 3))
    splats.scales[:] = 0.01
    splats.opacities[:] = 0.05
    points = _world(splats)
    shown = visible_bounds(points, splats.opacities, splats.scales)
    every = framing.robust_bounds(points)
    np.testing.assert_array_equal(shown.low, every.low)
    np.testing.assert_array_equal(shown.high, every.high)


def test_a_large_capture_is_sampled_and_floaters_and_nan_are_ignored():
    """300k splats (a strided sample stands for them), far floaters and a NaN centre: still
    the subject's box."""
    parts = [haloed_capture(seed=seed) for seed in range(7)]
    points = np.concatenate([_world(p) for p in parts])
    opacities = np.concatenate([p.opacities for p in parts])
    scales = np.concatenate([p.scales for p in parts])
    points[::5000] = 1000.0  # floaters, opaque
    points[7] = np.nan
    subject = framing.robust_bounds(np.concatenate([_world(p)[:SUBJECT] for p in parts]))
    shown = visible_bounds(points, opacities, scales)
    np.testing.assert_allclose(shown.low, subject.low, atol=0.02 * subject.size)
    np.testing.assert_allclose(shown.high, subject.high, atol=0.02 * subject.size)
