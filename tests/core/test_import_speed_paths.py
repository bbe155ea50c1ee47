"""The import's faster paths against the code they replace (issue 29).

framing.view_rotations (every orbit azimuth at once, for fill_distance) is pinned to
_pose_at's rotation, one look_at and two inverses per view, across up and forward axes,
elevations (the look_at fallback straight along up included), azimuths and bounds far
from the origin; fill_distance's answer is checked through _pose_at's own poses.
framing.rows_times (products a block of rows at a time) equals the whole product bit for
bit; validate's row checks without BLAS equal isfinite().all() on planted NaN, Inf and
sums that overflow, in every layout the readers give.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from addon.core import framing, validate
from addon.core.splats import ARRAYS, SplatSet

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
@pytest.mark.parametrize("elevation", [0.0, 20.0, -35.0, 89.9])
def test_orbit_poses_are_pose_at_poses(up, forward, elevation):
    """The orbit's poses, made all at once, are _pose_at's one by one to rounding: the
    rotation as view_rotations pins it, the eye to the rounding of distance x direction."""
    up, forward = _unit(up), _unit(forward)
    for centre, distance in (((0.0, 0.0, 0.0), 1.0), ((120.0, -40.0, 7.5), 3.0)):
        got = framing.orbit_poses(_bounds(centre), up, forward, distance, 120, elevation)
        want = [framing._pose_at(_bounds(centre), up, forward, distance, 2.0 * math.pi * i / 120,
                                 math.radians(elevation)) for i in range(120)]
        assert len(got) == 120 and all(p.shape == (4, 4) for p in got)
        np.testing.assert_allclose(np.stack(got), np.stack(want), rtol=0, atol=1e-11)


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


@pytest.mark.parametrize("count", [0, 1, 2, 2047, 2048, 2049, 4097, 100_003, 1_000_000])
def test_rows_times_equals_the_whole_product(count):
    rng = np.random.default_rng(count)
    rows = rng.normal(size=(count, 3)) * 100.0 + 40.0
    matrix = rng.normal(size=(3, 3))
    vector = rng.normal(size=3)
    for other in (matrix, matrix.T, vector):
        got, want = framing.rows_times(rows, other), rows @ other
        assert got.dtype == want.dtype and got.shape == want.shape
        np.testing.assert_array_equal(got, want)


def test_in_box_is_the_rows_all_within_the_bounds():
    """front_direction's mask, a bound at a time, is the readable whole-row comparison,
    points on the bounds included."""
    rng = np.random.default_rng(5)
    pts = rng.normal(size=(50_000, 3)) * (1.0, 2.0, 0.5)
    bounds = framing.robust_bounds(pts)
    pts[:10] = bounds.low  # on the box's faces
    pts[10:20] = bounds.high
    pts[20, 1] = np.nan
    want = ((pts >= bounds.low) & (pts <= bounds.high)).all(axis=1)
    got = framing._in_box(pts, bounds)
    assert got.dtype == bool and np.array_equal(got, want) and want[:20].all() and not want[20]


def _planted(count=5000, degree=3, seed=0):
    rng = np.random.default_rng(seed)
    splats = SplatSet.allocate(count, degree)
    for name in ("positions", "scales", "rotations", "sh_dc", "sh_rest"):
        values = getattr(splats, name)
        values[...] = rng.normal(size=values.shape)
    splats.scales[...] = np.abs(splats.scales) + 0.01
    splats.opacities[:] = rng.uniform(size=count)
    big = np.float32(3e38)  # finite, but rows of them sum to inf: flagged, then cleared
    for name, row in (("positions", 10), ("scales", 11), ("rotations", 12), ("sh_dc", 13), ("sh_rest", 14)):
        getattr(splats, name)[row] = big
    splats.positions[20, 1], splats.scales[21, 2], splats.rotations[22, 0] = np.nan, np.inf, -np.inf
    splats.opacities[23], splats.sh_dc[24, 0] = np.nan, np.inf
    splats.sh_rest[25, 14, 2], splats.sh_rest[26, 0, 0], splats.sh_rest[27, 7, 1] = np.nan, -np.inf, np.inf
    splats.rotations[30] = 0.0
    splats.rotations[31] = (-0.0, 0.0, 0.0, 0.0)
    splats.rotations[32] = (1e-40, 0.0, 0.0, 0.0)  # a subnormal is not zero
    splats.scales[33], splats.scales[34, 1], splats.scales[35, 0] = -1.0, 0.0, -0.0
    return splats


def _as_planes(sh_rest):
    """sh_rest stored as coefficient planes, as formats/ply.py gives it."""
    planes = np.ascontiguousarray(sh_rest.transpose(1, 0, 2))
    return planes.transpose(1, 0, 2)


@pytest.mark.parametrize("layout", ["contiguous", "planes"])
def test_find_bad_without_blas_equals_isfinite(layout):
    splats = _planted()
    if layout == "planes":
        splats.sh_rest = _as_planes(splats.sh_rest)
        assert not splats.sh_rest.flags.c_contiguous
    nonfinite, zero_q, nonpos, by_field = validate.find_bad(splats)
    want_nonfinite = np.zeros(splats.count, bool)
    for name in ARRAYS:
        values = getattr(splats, name)
        rows = ~np.isfinite(values.reshape(splats.count, -1)).all(axis=1)
        assert by_field[name] == int(rows.sum()), name
        want_nonfinite |= rows
    np.testing.assert_array_equal(nonfinite, want_nonfinite)
    assert sorted(np.flatnonzero(nonfinite)) == [20, 21, 22, 23, 24, 25, 26, 27]
    np.testing.assert_array_equal(zero_q, ~splats.rotations.any(axis=1) & ~want_nonfinite)
    assert list(np.flatnonzero(zero_q)) == [30, 31]
    np.testing.assert_array_equal(nonpos, (splats.scales.min(axis=1) <= 0) & ~want_nonfinite)
    assert list(np.flatnonzero(nonpos)) == [33, 34, 35]


@pytest.mark.parametrize("width", [1, 3, 4, 8, 9, 45])
def test_row_sums_flag_what_isfinite_flags(width):
    rng = np.random.default_rng(width)
    values = rng.normal(size=(3000, width)).astype(np.float32)
    values[5, width - 1], values[6, 0], values[7, width // 2] = np.nan, np.inf, -np.inf
    values[8] = 3e38
    np.testing.assert_array_equal(validate._rows_nonfinite(values), ~np.isfinite(values).all(axis=1))


@pytest.mark.parametrize("axes", ["AUTO", "RUB", "RFU"])
def test_framing_a_fresh_import_reads_its_own_transform(bpy_empty, testdata, axes):
    """No depsgraph update for objects placed by their own transform: their matrix_basis is
    the matrix_world an update gives, bit for bit; parented, constrained or animated objects
    are evaluated first."""
    from addon.blender.data import capture_camera, files

    bpy = bpy_empty
    obj = files.import_file(bpy.context, str(testdata / "guitar.ply"), axes=axes)
    obj.location, obj.scale = (0.5, -2.0, 1.25), (2.0, 0.5, 1.5)
    obj.delta_location = (0.25, 0.0, -1.0)
    assert capture_camera._own_transforms([obj])
    own = capture_camera.splat_world_points([obj], own_transforms=True)
    bpy.context.view_layer.update()
    np.testing.assert_array_equal(own, capture_camera.splat_world_points([obj]))
    np.testing.assert_array_equal(np.array(obj.matrix_basis), np.array(obj.matrix_world))

    constraint = obj.constraints.new("COPY_LOCATION")
    assert not capture_camera._own_transforms([obj])
    obj.constraints.remove(constraint)
    obj.keyframe_insert("location")
    assert not capture_camera._own_transforms([obj])
    obj.animation_data_clear()
    parent = bpy.data.objects.new("parent", None)
    bpy.context.scene.collection.objects.link(parent)
    obj.parent, parent.location = parent, (10.0, 0.0, 0.0)
    assert not capture_camera._own_transforms([obj])
    capture_camera.add_framing_camera(bpy.context, [obj], "front", 1, 1)
    assert obj.matrix_world.translation.x == pytest.approx(10.75)  # evaluated: the parent counts
