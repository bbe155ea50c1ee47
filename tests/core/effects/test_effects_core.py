"""Effect kernels against hand-computed expectations on a few splats (pure numpy, no bpy)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from addon.core.effects import (Displace, Explode, Grade, Morph, Reveal, Twist, evaluate_stack,
                                pair)
from addon.core.effects import noise
from addon.core.sh import C0
from addon.core.splats import SplatSet

F32_TOL = 1e-5  # float32 arithmetic on values of order 1: a few ulps


def make(positions, degree=1) -> SplatSet:
    pos = np.asarray(positions, np.float32)
    s = SplatSet.allocate(len(pos), degree)
    s.positions[:] = pos
    s.scales[:] = 0.1
    s.opacities[:] = 0.8
    s.sh_dc[:] = np.linspace(-0.5, 0.5, 3 * len(pos), dtype=np.float32).reshape(-1, 3)
    s.sh_rest[:] = 0.05
    return s.check()


def frame(translation=(0, 0, 0), scale=1.0) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] *= scale
    m[:3, 3] = translation
    return m


LINE = [[0, 0, z] for z in (-1.0, 0.0, 0.5, 1.0, 2.0)]


def test_reveal_plane_hand_computed():
    s = make(LINE)
    p = Reveal(progress=0.5, width=1.0, shrink=0.5, amount=1.0)
    got = evaluate_stack(s, [p], 0.0)
    # s = clip((0.5 - z)/1 + 0.5) = [1, 1, 0.5, 0, 0]; visibility = smoothstep(s)
    vis = np.array([1, 1, 0.5, 0, 0], np.float32)
    np.testing.assert_allclose(got.splats.opacities, 0.8 * vis, atol=F32_TOL)
    np.testing.assert_allclose(got.splats.scales[:, 0], 0.1 * (1 - 0.5 * (1 - vis)), atol=F32_TOL)
    assert got.splats.positions is s.positions and not got.positions_changed
    assert got.splats.sh_dc is s.sh_dc and got.splats.sh_rest is s.sh_rest


def test_reveal_invert_blend_glow_and_gizmo():
    s = make(LINE)
    # gizmo moved up by 1: local height = z - 1; amount 0.5 halves the fade
    p = Reveal(progress=0.0, width=0.0, invert=True, shrink=0.0, amount=0.5,
               glow_strength=1.0, frame=frame((0, 0, 1)))
    out = evaluate_stack(s, [p], 0.0).splats
    # hard edge: s = (h < 0); invert keeps h >= 0, i.e. z in {1, 2}
    shown = np.array([0, 0, 0, 1, 1], np.float32)
    np.testing.assert_allclose(out.opacities, 0.8 * (1 - 0.5 * (1 - shown)), atol=F32_TOL)
    assert out.scales is s.scales
    np.testing.assert_array_equal(out.sh_dc, s.sh_dc)  # hard edge: glow 4 s (1-s) is 0


def test_reveal_glow_added_to_dc_at_the_edge():
    s = make([[0, 0, 0.5]])
    p = Reveal(progress=0.5, width=1.0, glow_strength=2.0, glow_color=(1.0, 0.5, 0.0))
    out = evaluate_stack(s, [p], 0.0).splats
    # s = 0.5 at the threshold: glow = 4 * 0.25 * 2 = 2 in colour, /C0 in DC units
    np.testing.assert_allclose(out.sh_dc - s.sh_dc, [[2 / C0, 1 / C0, 0]], rtol=1e-5)


def test_reveal_sphere_uses_distance():
    s = make([[0, 0, 0], [3, 4, 0], [0, 0, 0.9]])
    out = evaluate_stack(s, [Reveal(shape="SPHERE", progress=1.0, width=0.0)], 0.0).splats
    np.testing.assert_allclose(out.opacities, [0.8, 0.0, 0.8], atol=F32_TOL)


def test_noise_is_smooth_seeded_and_interpolates_the_lattice():
    x = np.array([2.0, 2.5, 3.0], np.float32)
    y = np.full(3, 5.0, np.float32)
    z = np.full(3, 7.0, np.float32)
    v = noise.value_noise(x, y, z, seed=3)[0]
    a, b = noise.lattice_value(3, 0, 2, 5, 7), noise.lattice_value(3, 0, 3, 5, 7)
    # at lattice points the value is the lattice value; halfway the cubic weight is 0.5
    np.testing.assert_allclose(v, [a, 0.5 * (a + b), b], atol=F32_TOL)
    other = noise.value_noise(x, y, z, seed=4)[0]
    assert not np.allclose(v, other)
    # periodic every PERIOD cells, continuous: a small step gives a small change
    wrapped = noise.value_noise(x + noise.PERIOD, y, z, seed=3)[0]
    np.testing.assert_allclose(wrapped, v, atol=F32_TOL)
    eps = np.float32(1e-3)
    step = noise.value_noise(x + eps, y, z, seed=3)[0]
    assert np.abs(step - v).max() < 0.01


def test_displace_hand_computed_and_continuous_in_time():
    s = make([[0.25, 1.5, -2.0], [4.0, 0.0, 1.0]])
    p = Displace(amplitude=0.3, frequency=2.0, speed=0.5, seed=9, amount=0.5)
    t = 2.6  # u = 1.3: layers 1 and 2, s = smoothstep(0.3) = 0.216
    out = evaluate_stack(s, [p], t)
    assert out.positions_changed
    q = s.positions.astype(np.float64) * 2.0
    n1 = np.stack(noise.value_noise(q[:, 0], q[:, 1], q[:, 2], 9, 3, layer=1), 1)
    n2 = np.stack(noise.value_noise(q[:, 0], q[:, 1], q[:, 2], 9, 3, layer=2), 1)
    w = 0.3 * 0.3 * (3 - 2 * 0.3)
    blend = ((1 - w) * n1 + w * n2) / np.sqrt((1 - w) ** 2 + w * w)
    np.testing.assert_allclose(out.splats.positions, s.positions + 0.15 * blend, atol=1e-5)
    # continuous in time, also across a layer boundary (u = 2 at t = 4)
    for a, b in ((t, t + 1e-4), (4.0 - 1e-4, 4.0)):
        pa = evaluate_stack(s, [p], a).splats.positions
        pb = evaluate_stack(s, [p], b).splats.positions
        assert np.abs(pa - pb).max() < 1e-3
    assert out.splats.opacities is s.opacities and out.splats.sh_dc is s.sh_dc


def test_noise_field_memo_gives_the_same_bits_as_a_fresh_evaluation():
    s = make(np.random.default_rng(1).normal(size=(100, 3)))
    p = Displace(amplitude=0.2, speed=0.7, seed=4)
    noise.FIELDS.clear()
    fresh = evaluate_stack(s, [p], 3.3).splats.positions
    memo = evaluate_stack(s, [p], 3.3).splats.positions  # now from the memo
    np.testing.assert_array_equal(fresh, memo)
    other = make(s.positions.copy())  # equal values, another array: evaluated again
    np.testing.assert_array_equal(evaluate_stack(other, [p], 3.3).splats.positions, fresh)


def test_explode_closed_form():
    s = make([[1, 0, 0], [0, 2, 0], [0, 0, -3]])
    p = Explode(mode="CENTER", strength=2.0, spread=0.0, gravity=4.0, start=1.0, fade=0.5,
                amount=1.0)
    tau = 1.5
    out = evaluate_stack(s, [p], 1.0 + tau).splats
    radial = s.positions / np.linalg.norm(s.positions, axis=1, keepdims=True)
    expect = s.positions + 2.0 * tau * radial - np.array([0, 0, 0.5 * 4.0 * tau * tau])
    np.testing.assert_allclose(out.positions, expect, atol=1e-5)
    np.testing.assert_allclose(out.opacities, 0.8 * math.exp(-0.5 * tau), rtol=1e-6)
    # before the start nothing moves, and any frame can be evaluated out of order
    assert evaluate_stack(s, [p], 0.5).splats is s
    again = evaluate_stack(s, [p], 1.0 + tau).splats
    np.testing.assert_array_equal(again.positions, out.positions)


def test_explode_direction_spin_keeps_unit_quaternions():
    s = make([[0, 0, 0], [1, 1, 1]])
    p = Explode(mode="DIRECTION", strength=1.0, spread=0.0, spin=2.0, frame=frame((5, 5, 5)))
    out = evaluate_stack(s, [p], 0.5).splats
    np.testing.assert_allclose(out.positions, s.positions + [0, 0, 0.5], atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(out.rotations, axis=1), 1.0, atol=1e-6)
    # rotation angle of each splat = spin * tau = 1 rad: w = cos(0.5)
    np.testing.assert_allclose(out.rotations[:, 0], math.cos(0.5), atol=1e-6)


def test_twist_rotates_by_height():
    s = make([[1, 0, 0], [1, 0, 1], [0, 2, 2]])
    p = Twist(twist=math.pi / 2, amount=1.0)
    out = evaluate_stack(s, [p], 0.0).splats
    # angle = pi/2 * z about +z: (1,0,0)->(1,0,0); (1,0,1)->(0,1,1); (0,2,2) by pi -> (0,-2,2)
    np.testing.assert_allclose(out.positions, [[1, 0, 0], [0, 1, 1], [0, -2, 2]], atol=1e-6)
    np.testing.assert_allclose(out.rotations[1], [math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4)],
                               atol=1e-6)
    assert out.opacities is s.opacities


def test_swirl_falls_off_with_radius():
    s = make([[1, 0, 0], [0, 0, 0]])
    out = evaluate_stack(s, [Twist(twist=0.0, swirl=1.0, radius=1.0)], 0.0).splats
    angle = math.exp(-1.0)
    np.testing.assert_allclose(out.positions[0], [math.cos(angle), math.sin(angle), 0], atol=1e-6)


@pytest.mark.parametrize("mode", ["MIX", "MULTIPLY", "ADD"])
def test_grade_by_height_hand_computed(mode):
    s = make([[0, 0, 0], [0, 0, 0.5], [0, 0, 2]])
    stops = ((0.0, (0.0, 0.0, 1.0)), (1.0, (1.0, 0.0, 0.0)))
    out = evaluate_stack(s, [Grade(field="HEIGHT", stops=stops, mode=mode, amount=0.5)], 0.0)
    g = np.array([[0, 0, 1], [0.5, 0, 0.5], [1, 0, 0]])
    c = C0 * s.sh_dc.astype(np.float64) + 0.5
    expect = {"MIX": c + 0.5 * (g - c), "MULTIPLY": c * (1 + 0.5 * (g - 1)), "ADD": c + 0.5 * g}[mode]
    np.testing.assert_allclose(C0 * out.splats.sh_dc + 0.5, expect, atol=F32_TOL)
    assert out.splats.positions is s.positions and not out.positions_changed
    assert out.splats.sh_rest is s.sh_rest


def test_grade_three_stops_and_distance():
    s = make([[0, 0, 0], [0, 3, 4]])
    stops = ((0.0, (0, 0, 0)), (0.5, (1, 1, 1)), (1.0, (0, 1, 0)))
    out = evaluate_stack(s, [Grade(field="DISTANCE", stops=stops, low=0.0, high=10.0)], 0.0)
    np.testing.assert_allclose(C0 * out.splats.sh_dc + 0.5, [[0, 0, 0], [1, 1, 1]], atol=F32_TOL)


def test_morph_ends_equal_source_and_target_and_midpoint():
    src = make([[0, 0, 0], [1, 0, 0]])
    tgt = make([[0, 2, 0], [1, 2, 2]], degree=0)
    tgt.rotations[:] = [math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4)]  # 90 deg about z
    tgt.opacities[:] = 0.2
    assert evaluate_stack(src, [Morph(target=tgt, amount=0.0)], 0.0).splats is src
    one = evaluate_stack(src, [Morph(target=tgt, amount=1.0)], 0.0).splats
    for name in ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest"):
        np.testing.assert_array_equal(getattr(one, name), getattr(tgt, name))
    half = evaluate_stack(src, [Morph(target=tgt, amount=0.5)], 0.0).splats
    np.testing.assert_allclose(half.positions, [[0, 1, 0], [1, 1, 1]], atol=1e-6)
    np.testing.assert_allclose(half.opacities, 0.5, atol=1e-6)
    # slerp halfway: 45 degrees about z
    np.testing.assert_allclose(half.rotations[0], [math.cos(math.pi / 8), 0, 0, math.sin(math.pi / 8)],
                               atol=1e-6)
    np.testing.assert_allclose(half.sh_rest, 0.025, atol=1e-7)  # degree 1 vs zero-padded degree 0


def test_morph_unequal_counts_pairs_spatially_and_fades_the_rest():
    src = make([[0, 0, 0], [10, 0, 0], [5, 0, 0], [9.9, 0, 0]])
    tgt = make([[0, 1, 0], [10, 1, 0]])
    pairing = pair(src.positions, tgt.positions)
    assert len(pairing.source) == 2 and len(pairing.source_only) == 2
    assert len(pairing.target_only) == 0
    # spatial order along the line: pairs stay local (distance along x small)
    gap = np.abs(src.positions[pairing.source, 0] - tgt.positions[pairing.target, 0])
    assert gap.max() <= 5.0
    out = evaluate_stack(src, [Morph(target=tgt, amount=0.25)], 0.0).splats
    # in the larger set's order: each source splat where it was, the lone ones fading in place
    assert out.count == 4
    lone = pairing.source_only
    np.testing.assert_allclose(out.opacities[lone], [0.6, 0.6], atol=1e-6)  # 0.8 * 0.75
    np.testing.assert_array_equal(out.positions[lone], src.positions[lone])
    np.testing.assert_allclose(out.positions[pairing.source],
                               0.75 * src.positions[pairing.source] + 0.25 * tgt.positions[pairing.target],
                               atol=1e-6)
    # the reverse direction: unpaired target splats fade in, in the target's order
    back = pair(tgt.positions, src.positions)
    assert len(back.target_only) == 2 and len(back.source_only) == 0
    rev = evaluate_stack(tgt, [Morph(target=src, amount=0.25)], 0.0).splats
    np.testing.assert_allclose(rev.opacities[back.target_only], 0.2, atol=1e-6)  # 0.8 * 0.25
    np.testing.assert_array_equal(rev.positions[back.target_only], src.positions[back.target_only])


def test_stack_is_pure_and_never_writes_its_input():
    s = make(np.random.default_rng(0).normal(size=(50, 3)))
    frozen = {k: getattr(s, k).copy() for k in ("positions", "scales", "rotations", "opacities",
                                                 "sh_dc", "sh_rest")}
    for name in frozen:
        getattr(s, name).flags.writeable = False
    stack = [Reveal(shape="NOISE", progress=0.5, glow_strength=1.0), Displace(seed=2),
             Explode(spin=1.0, spread=0.5), Twist(swirl=1.0), Grade(field="NOISE"),
             Morph(target=make(np.zeros((30, 3))), amount=0.3)]
    a = evaluate_stack(s, stack, 2.5).splats
    evaluate_stack(s, stack, 0.7)
    b = evaluate_stack(s, stack, 2.5).splats
    for name, value in frozen.items():
        np.testing.assert_array_equal(getattr(s, name), value)
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    a.check()


def test_disabled_or_zero_amount_effects_return_the_input():
    s = make(LINE)
    for p in (Reveal(enabled=False), Displace(amount=0.0), Grade(enabled=False), Twist(amount=0.0)):
        assert evaluate_stack(s, [p], 1.0).splats is s


def test_degenerate_gizmo_and_empty_sets_do_not_stop_evaluation():
    s = make(LINE)
    flat = frame(scale=0.0)  # an Empty scaled to 0: singular
    for p in (Reveal(frame=flat), Twist(frame=flat), Grade(frame=flat), Displace(frame=flat)):
        out = evaluate_stack(s, [p], 1.0).splats
        assert np.isfinite(out.positions).all() and np.isfinite(out.opacities).all()
    empty = SplatSet.allocate(0, 1)
    grown = evaluate_stack(empty, [Morph(target=s, amount=0.5)], 0.0).splats
    np.testing.assert_allclose(grown.opacities, 0.4)  # all target splats fade in
    gone = evaluate_stack(s, [Morph(target=empty, amount=0.25)], 0.0).splats
    np.testing.assert_allclose(gone.opacities, 0.6)   # all source splats fade out


def test_noise_is_sampled_at_rest_positions_so_it_stays_on_moving_splats():
    s = make(np.random.default_rng(2).uniform(-1, 1, (40, 3)))
    twist = Twist(twist=1.0)
    displace = Displace(amplitude=0.2, speed=0.0, seed=3)
    dissolve = Reveal(shape="NOISE", progress=0.5, width=0.2, seed=6)
    twisted = evaluate_stack(s, [twist], 0.0).splats
    out = evaluate_stack(s, [twist, displace, dissolve], 0.0).splats
    q = s.positions.astype(np.float64)  # the rest centres, gizmo frame = identity, frequency 1
    n = np.stack(noise.value_noise(q[:, 0], q[:, 1], q[:, 2], 3, 3, layer=0), 1)
    np.testing.assert_allclose(out.positions, twisted.positions + 0.2 * n, atol=1e-5)
    alone = evaluate_stack(s, [dissolve], 0.0).splats  # same pattern as without the motion
    np.testing.assert_array_equal(out.opacities, alone.opacities)
