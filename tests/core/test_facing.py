"""The side a capture was photographed from (core/facing.py) and the front it picks
(framing.front_direction): generated shells with a known face, closed ones, and the real
captures' facings."""
from __future__ import annotations

import math

import numpy as np
import pytest

from addon.core import facing, formats, framing
from addon.core.axes import matrix_for
from testing.framing_captures import one_sided_shell

UP = np.array([0.0, 0.0, 1.0])


def _placed(splats, turn_deg=0.0, scale=1.0):
    """World centres and normals of `splats` imported (the axis rotation), turned about
    Blender's z and scaled: (points, normals, weights, linear)."""
    c, s = math.cos(math.radians(turn_deg)), math.sin(math.radians(turn_deg))
    linear = scale * np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ matrix_for(splats.axes)
    points = splats.positions.astype(np.float64) @ linear.T
    normals, flatness = facing.splat_normals(splats.rotations, splats.scales, linear)
    return points, normals, flatness * splats.opacities, linear


def _azimuth(direction) -> float:
    """Degrees counter-clockwise (seen from above) from Blender's -y."""
    return math.degrees(math.atan2(direction[0], -direction[1]))


@pytest.mark.parametrize("facing_deg, turn_deg", [(0.0, 0.0), (180.0, 0.0), (100.0, 0.0), (-65.0, 30.0)])
def test_a_one_sided_shell_faces_where_it_was_photographed(facing_deg, turn_deg):
    splats = one_sided_shell(facing_deg=facing_deg)
    points, normals, weights, linear = _placed(splats, turn_deg, scale=2.5)
    bounds = framing.robust_bounds(points)
    faces = facing.facing(points, normals, weights, bounds.centre, UP)
    print(f"facing {facing_deg} turned {turn_deg}: {_azimuth(faces):.1f} deg, sure {np.linalg.norm(faces):.3f}")
    assert np.linalg.norm(faces) == pytest.approx(0.5, abs=0.03)  # a hemisphere's mean outward normal
    want = facing_deg + turn_deg
    assert abs((_azimuth(faces) - want + 180.0) % 360.0 - 180.0) < 2.0
    up, ahead = framing.capture_axes(splats.axes, np.pad(linear, (0, 1)) + np.diag([0, 0, 0, 1]))
    front = framing.front_direction(points, bounds, up, ahead, faces)
    # the front view looks back at the photographed side, whichever way the file's camera looked
    assert front @ faces / np.linalg.norm(faces) < -0.999, (front, faces)


def test_the_old_front_showed_the_back_of_a_shell_photographed_from_behind_the_files_camera():
    """Without the facing, front looks the way the file's camera looked (+y once imported)
    and sees the inside of a shell that faces away from it; with it, the outside."""
    splats = one_sided_shell(facing_deg=180.0)
    points, normals, weights, linear = _placed(splats)
    bounds = framing.robust_bounds(points)
    ahead = np.array([0.0, 1.0, 0.0])
    faces = facing.facing(points, normals, weights, bounds.centre, UP)
    old = framing.front_direction(points, bounds, UP, ahead)
    new = framing.front_direction(points, bounds, UP, ahead, faces)
    np.testing.assert_allclose(old, [0.0, 1.0, 0.0], atol=0.01)  # stands at -y: the open back
    np.testing.assert_allclose(new, [0.0, -1.0, 0.0], atol=0.01)


def test_a_deep_trough_is_seen_from_its_open_side_not_across_its_thin_axis():
    """A half-shell three times deeper than wide (its least level spread across the
    opening's axis, 90 degrees from the facing): the facing decides, not the broad face."""
    splats = one_sided_shell(facing_deg=40.0, depth=3.0)
    splats.positions[:, 0] *= 0.4  # narrow: the least spread is across, not along the depth
    points, normals, weights, _ = _placed(splats)
    bounds = framing.robust_bounds(points)
    faces = facing.facing(points, normals, weights, bounds.centre, UP)
    front = framing.front_direction(points, bounds, UP, np.array([0.0, 1.0, 0.0]), faces)
    assert np.linalg.norm(faces) > framing.FACING_SURE
    assert front @ faces / np.linalg.norm(faces) < -0.99


def test_a_shell_closed_all_round_has_no_side():
    """Two halves facing opposite ways: no facing, so the front stays the broad face's,
    signed by the file's camera, as before."""
    a, b = one_sided_shell(facing_deg=0.0, seed=1), one_sided_shell(facing_deg=180.0, seed=2)
    pa, na, wa, _ = _placed(a)
    pb, nb, wb, _ = _placed(b)
    points, normals, weights = np.concatenate([pa, pb]), np.concatenate([na, nb]), np.concatenate([wa, wb])
    points[:, 0] *= 0.5  # a broad face across y (thin along x)
    bounds = framing.robust_bounds(points)
    faces = facing.facing(points, normals, weights, bounds.centre, UP)
    assert np.linalg.norm(faces) < 0.03
    ahead = np.array([0.3, 1.0, 0.0])
    front = framing.front_direction(points, bounds, UP, ahead, faces)
    np.testing.assert_array_equal(front, framing.front_direction(points, bounds, UP, ahead))


def test_splat_normals_are_the_thin_axis_turned_and_inverse_transposed():
    splats = one_sided_shell(n=200, facing_deg=0.0)
    normals, flatness = facing.splat_normals(splats.rotations, splats.scales)
    outward = splats.positions / np.linalg.norm(splats.positions, axis=1, keepdims=True)
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", normals, outward)), 1.0, atol=1e-5)
    np.testing.assert_allclose(flatness, 0.9, atol=1e-6)  # 0.003 over 0.03
    squash = np.diag([1.0, 1.0, 0.25])  # a non-uniform scale tilts normals the other way
    world, _ = facing.splat_normals(splats.rotations, splats.scales, squash)
    want = normals @ np.linalg.inv(squash)
    np.testing.assert_allclose(world, want / np.linalg.norm(want, axis=1, keepdims=True), atol=1e-12)


@pytest.mark.parametrize("name", ["guitar.ply", "test64.ply"])
def test_real_captures_keep_their_front_axis(testdata, name):
    """guitar.ply's and test64.ply's flat splats face along the broad face's axis (within
    FACING_SNAP), so the front keeps that axis: the facing only picks its side."""
    splats = formats.read(testdata / name)
    points, normals, weights, linear = _placed(splats)
    bounds = framing.robust_bounds(points)
    faces = facing.facing(points, normals, weights, bounds.centre, UP)
    ahead = np.array([0.0, 1.0, 0.0])
    old, new = (framing.front_direction(points, bounds, UP, ahead, f) for f in (None, faces))
    print(f"{name}: facing {_azimuth(faces):.1f} deg, sure {np.linalg.norm(faces):.3f}; front looks "
          f"{_azimuth(old):.1f} -> {_azimuth(new):.1f}")
    assert np.linalg.norm(faces) > framing.FACING_SURE
    assert abs(old @ new) == pytest.approx(1.0, abs=1e-9)
