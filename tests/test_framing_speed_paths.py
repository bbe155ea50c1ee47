"""The import's faster paths against the code they replace (issue 29).

framing.view_rotations (every orbit azimuth at once, for fill_distance) is pinned to
_pose_at's rotation, one look_at and two inverses per view, across up and forward axes,
elevations (the look_at fallback straight along up included), azimuths and bounds far
from the origin; fill_distance's answer is checked through _pose_at's own poses.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from addon.core import framing

AXES = [  # (up, forward): the capture frames' own, a tilted capture, a forward not level
    ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
    ((0.0, -1.0, 0.0), (0.0, 0.0, 1.0)),
    ((0.0, 1.0, 0.0), (0.0, 0.0, -1.0)),
    ((0.3, -0.2, 0.9), (0.1, 0.8, 0.4)),
    ((0.0, 0.0, 1.0), (0.6, 0.5, -0.7)),
]
ELEVATIONS = [0.0, 20.0, -35.0, 89.9, 90.0, -90.0]


def _unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v)


def _bounds(centre):
    centre = np.asarray(centre, np.float64)
    return framing.Bounds(centre, centre - (1.0, 2.0, 0.5), centre + (1.0, 2.0, 0.5))


@pytest.mark.parametrize("up,forward", AXES)
@pytest.mark.parametrize("elevation", ELEVATIONS)
def test_view_rotations_equal_pose_at(up, forward, elevation):
    up, forward = _unit(up), _unit(forward)
    if abs(elevation) == 90.0 and abs(up[1]) > 0.9:
        pytest.skip("straight along a y up: look_at's fallback axis is up itself, no view at all")
    azimuths = np.concatenate([framing.orbit_azimuths(), [-1.0, 0.5 * math.pi, 7.0]])
    got = framing.view_rotations(up, forward, azimuths, math.radians(elevation))
    assert got.shape == (len(azimuths), 3, 3)
    for centre, distance in (((0.0, 0.0, 0.0), 1.0), ((120.0, -40.0, 7.5), 3.0)):
        want = np.stack([framing._pose_at(_bounds(centre), up, forward, distance, a,
                                          math.radians(elevation))[:3, :3] for a in azimuths])
        # 1e-11: near straight up, right is short (1.7e-3 at 89.9 degrees) and _pose_at's
        # eye - centre rounding (1e-14 at a centre 120 away) is divided by its length
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-11)


@pytest.mark.parametrize("up,forward", AXES)
@pytest.mark.parametrize("elevation", [0.0, 20.0, -35.0])
def test_fill_distance_fills_through_pose_at(up, forward, elevation):
    """The distance found fills FILL in the widest of the views as _pose_at poses them, and
    a step nearer overfills: the bisection's answer, whatever computed its views."""
    up, forward = _unit(up), _unit(forward)
    bounds = _bounds((3.0, -1.0, 2.0))
    tans = (0.36, 0.2025)
    azimuths = framing.orbit_azimuths()
    distance = framing.fill_distance(bounds, up, forward, *tans, elevation_deg=elevation, azimuths=azimuths)
    corners = framing.box_corners(bounds)

    def widest(d):
        return max(framing.frame_fill(corners, framing._pose_at(bounds, up, forward, d, a, math.radians(elevation)),
                                      *tans) for a in azimuths)

    assert widest(distance) == pytest.approx(framing.FILL, abs=1e-9)
    assert widest(distance * (1.0 - 1e-6)) > framing.FILL
