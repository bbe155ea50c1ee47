"""Turning splats into another frame without bpy (core/reframe.py, core/quaternion.py): a
morph target mapped into its source object's space, and the quaternion maths under it."""
from __future__ import annotations

import numpy as np

from addon.core import quaternion
from addon.core.colorspace import premultiplied_srgb_to_linear, srgb_to_linear
from testing.synth import random_splats
from addon.core.reframe import map_into
from addon.core.sh import sh_to_rgb
from testing.reference_oracle import quat_matrix


def _turn(axis, degrees) -> np.ndarray:
    a = np.asarray(axis, np.float64) / np.linalg.norm(axis)
    t = np.radians(degrees)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(t) * k + (1 - np.cos(t)) * k @ k


def test_map_into_turns_moves_and_scales_every_part_of_a_splat():
    splats = random_splats(200, 3, seed=11)
    rot = _turn((0.3, -1.0, 0.6), 71.0)
    relative = np.eye(4)
    relative[:3, :3] = 2.5 * rot
    relative[:3, 3] = (0.4, -1.2, 3.0)
    mapped = map_into(splats, relative)
    expected = splats.positions.astype(np.float64) @ relative[:3, :3].T + relative[:3, 3]
    np.testing.assert_allclose(mapped.positions, expected, rtol=1e-6, atol=1e-5)
    np.testing.assert_allclose(mapped.scales, splats.scales * 2.5, rtol=1e-6)
    for before, after in zip(splats.rotations[:20], mapped.rotations[:20]):
        np.testing.assert_allclose(quat_matrix(after), rot @ quat_matrix(before), atol=2e-6)
    # The view-dependent colour turns with the splat: seen from rot @ d as it was from d.
    dirs = np.random.default_rng(3).normal(size=(splats.count, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    before = sh_to_rgb(splats.sh_dc, splats.sh_rest, dirs, 3)
    after = sh_to_rgb(mapped.sh_dc, mapped.sh_rest, dirs @ rot.T, 3)
    np.testing.assert_allclose(after, before, atol=1e-4)
    np.testing.assert_array_equal(mapped.opacities, splats.opacities)


def test_map_into_leaves_a_collapsed_target_as_it_is():
    splats = random_splats(10, 1, seed=2)
    assert map_into(splats, np.diag([0.0, 1.0, 1.0, 1.0])) is splats


def test_quaternion_product_composes_the_rotations():
    rng = np.random.default_rng(5)
    a, b = rng.normal(size=(50, 4)), rng.normal(size=(50, 4))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    ab = quaternion.multiply(a, b)
    assert ab.dtype == np.float32 and ab.shape == (50, 4)
    for qa, qb, q in zip(a, b, ab):
        np.testing.assert_allclose(quat_matrix(q), quat_matrix(qa) @ quat_matrix(qb), atol=1e-6)
    # One quaternion (4,) against many, as reframe uses it.
    one = quaternion.multiply(a[0], b)
    np.testing.assert_allclose(one, quaternion.multiply(np.broadcast_to(a[0], b.shape), b))


def test_from_matrix_inverts_the_rotation_matrix_near_180_degrees_too():
    turns = [_turn(axis, deg) for axis, deg in (((1, 0, 0), 180.0), ((0, 1, 1), 179.99),
                                                ((1, 2, 3), 37.0), ((0, 0, 1), 0.0))]
    q = quaternion.from_matrix(np.stack(turns))
    assert np.all(q[:, 0] >= 0)
    for m, qi in zip(turns, q):
        np.testing.assert_allclose(quat_matrix(qi), m, atol=1e-12)


def test_one_srgb_curve_in_float32_and_float64():
    x = np.linspace(-1.5, 1.5, 10001)
    wide = srgb_to_linear(x)
    narrow = srgb_to_linear(x.astype(np.float32), np.float32)
    assert narrow.dtype == np.float32
    np.testing.assert_allclose(narrow, wide, rtol=1e-6, atol=1e-9)
    np.testing.assert_array_equal(np.sign(wide), np.sign(x))  # mirrored below 0
    rgba = np.array([[0.25, 0.1, 0.02, 0.5]], np.float32)
    out = premultiplied_srgb_to_linear(rgba)
    np.testing.assert_allclose(out[0, :3], srgb_to_linear(rgba[0, :3] / 0.5) * 0.5, rtol=1e-6)
