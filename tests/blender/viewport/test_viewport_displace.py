"""A displace the viewport applies in its preprocess pass (viewport_effects.glsl,
`displaced`) pinned to the numpy kernel (core/effects/displace.py), record by record,
across its parameters.

One draw holds two copies of a real capture (guitar.ply with its importer's axes, every
third splat, given degree-3 SH so the colour follows the view direction from the moved
centre): the first with the stack evaluated on the CPU and uploaded whole, the second with
the displace deferred (the pos texture keeps the rest centres; the noise layers go up as
the displace_a and displace_b textures). Both copies share their scales, rotations and SH,
so their records differ only by the float rounding of the blend (the GPU may fuse its
multiply-adds): far below what the displacement moves them.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from addon.core.effects import Displace, Grade, Reveal, evaluate_stack
from addon.core.effects.deferral import drawn_splats, split_stack
from addon.core.formats import read
from addon.core.scene import RenderItem
from testing.effect_cases import FRAMES, varied
from testing.gl_scenes import framing_camera, world_for
from testing.viewport_scene import by_splat, records

CENTRE_PX = 1e-4  # pixels: the centres' bar (a blend's rounding moves them ~1e-5 here)
MOVED_PX = 0.05   # what most splats' displacement moves their centres by, at least


@pytest.fixture(scope="module")
def capture(testdata):
    full = read(testdata / "guitar.ply")
    assert full.axes is not None  # the capture's own axes: not an identity scene
    splats = full.subset(np.arange(0, full.count, 3))
    rng = np.random.default_rng(3)
    splats = replace(splats, sh_rest=rng.normal(0.0, 0.15, (splats.count, 15, 3)).astype(np.float32))
    world = world_for(splats)
    return splats, world, framing_camera(RenderItem(splats, world), 160, 120)


def cases():
    """(displace, time): two noise layers blended and one (speed x time a whole number,
    where the kernel reads one layer), each sign of speed, and the other settings in turn."""
    for amplitude, speed, time, frequency, seed, amount, frame in varied(
            ((0.04, 0.3), (0.5, -1.5, 0.0), (0.9, 2.0)),
            ((0.5, 3.0), (0, 7), (0.4, 1.0), FRAMES)):
        yield Displace(amplitude=amplitude, speed=speed, frequency=frequency, seed=seed, amount=amount,
                       frame=frame), time


CASES = list(cases())


def test_the_cases_meet_every_branch():
    from addon.blender.viewport.effect_rows import on_gpu
    from addon.core.effects.displace import noise_layers

    assert all(split_stack([p], on_gpu)[0] == [] for p, _ in CASES)
    positions = np.zeros((1, 3), np.float32)
    assert {len(noise_layers(positions, p, t)) for p, t in CASES} == {1, 2}
    assert {np.sign(p.speed) for p, _ in CASES} == {-1.0, 0.0, 1.0}
    assert {p.amount < 1.0 for p, _ in CASES} == {True, False}
    # nothing to move: left to the kernel, which returns its input without making layers
    assert not on_gpu(Displace(amplitude=0.0)) and not on_gpu(Displace(amplitude=float("nan")))


def _records(capture, stack, time):
    """Records of the CPU copy, the deferred copy and, for scale, the deferred copy drawn
    without its displace, of the splats all three draw (their indices, and the stack's
    and the CPU part's splats, last)."""
    from addon.blender.viewport import ViewportRenderer
    from addon.blender.viewport.effect_rows import on_gpu

    splats, world, camera = capture
    on_cpu, deferred = split_stack(stack, on_gpu)
    assert on_cpu == [] and Displace in [type(d.params) for d in deferred]
    cpu = evaluate_stack(splats, stack, time).splats
    part = evaluate_stack(splats, on_cpu, time).splats
    drawn, handed = drawn_splats(part, deferred, time)
    items = [RenderItem(cpu, world, key=("cpu",)),
             RenderItem(drawn, world, key=("gpu",), deferred=handed, rest_positions=splats.positions)]
    renderer = ViewportRenderer()
    records(items, camera, renderer)  # new layers: the CPU's centres drawn (_settled)
    assert "displace_a" not in renderer.gpu.textures
    want, got = by_splat(*records(items, camera, renderer), cpu.count)  # the same: the pass's
    assert {"displace_a", "displace_b"} <= set(renderer.gpu.textures)
    renderer.close()
    still = [d for d in handed if type(d.params) is not Displace]
    unmoved, _ = by_splat(*records([RenderItem(part, world, key=("still",), deferred=tuple(still),
                                               rest_positions=splats.positions)], camera), cpu.count)
    assert len(want) > 0.3 * cpu.count and set(want) <= set(got)  # in view; the same culling
    index = np.array(sorted(set(want) & set(unmoved)), np.int64)
    return [np.stack([r[i] for i in index]) for r in (want, got, unmoved)] + [index, cpu, part]


@pytest.mark.parametrize("case", range(len(CASES)))
def test_a_deferred_displace_draws_the_kernels_records(gpu_ready, capture, case):
    p, time = CASES[case]
    w, g, unmoved, *_ = _records(capture, [p], time)
    moved = np.hypot(*(w[:, 0:2] - unmoved[:, 0:2]).T)
    assert np.median(moved) > MOVED_PX  # the bar below is far under what the displace does
    np.testing.assert_allclose(g[:, 0:3], w[:, 0:3], rtol=0, atol=CENTRE_PX, err_msg="centre, depth")
    # a centre moved by ~1e-7 of itself moves the footprint and the view direction alike
    np.testing.assert_allclose(g[:, 3], w[:, 3], rtol=1e-5, atol=1e-4, err_msg="radius")
    conic_tol = 1e-5 * np.abs(w[:, 4:7]).max(1, keepdims=True) + 1e-9
    assert (np.abs(g[:, 4:7] - w[:, 4:7]) <= conic_tol).all(), "conic"
    np.testing.assert_allclose(g[:, 7], w[:, 7], rtol=1e-5, atol=1e-7, err_msg="opacity")
    np.testing.assert_allclose(g[:, 8:11], w[:, 8:11], rtol=0, atol=2e-5, err_msg="colour")


@pytest.mark.parametrize("time", (0.9, 2.0))
def test_colour_effects_around_it_read_the_centres_they_should(gpu_ready, capture, time):
    """A reveal before the displace measures the rest centres, a grade after it the moved
    ones (the GPU's): the colour matches the kernel's within the SH DC's rounding to halves
    (after the grade on the CPU copy, before it on the deferred one, as in
    test_viewport_effects) and the grade's slope times the centres' rounding, far below
    what the displacement changes."""
    from addon.core.sh import C0

    half_step = 2.0 ** -11
    splats = capture[0]
    z = splats.positions[:, 2]
    lo, hi = (float(v) for v in np.quantile(z, (0.1, 0.9)))
    reveal = Reveal(shape="PLANE", progress=0.5 * (lo + hi), width=0.5 * (hi - lo), glow_strength=0.0)
    grade = Grade(field="HEIGHT", low=lo, high=hi)
    displace = Displace(amplitude=0.3, frequency=2.0)
    w, g, unmoved, index, cpu, part = _records(capture, [reveal, displace, grade], time)
    np.testing.assert_allclose(g[:, 0:3], w[:, 0:3], rtol=0, atol=CENTRE_PX, err_msg="centre, depth")
    np.testing.assert_allclose(g[:, 7], w[:, 7], rtol=1e-5, atol=1e-7, err_msg="opacity")
    # the grade's gradient spans hi - lo: a centre's rounding (~1e-6) moves it ~1e-5
    halves = C0 * half_step * (np.abs(cpu.sh_dc[index]) + 2.0 * np.abs(part.sh_dc[index]))
    assert (np.abs(g[:, 8:11] - w[:, 8:11]) <= halves + 2e-5).all(), "colour"
    assert np.median(np.abs(w[:, 8:11] - unmoved[:, 8:11]).max(1)) > 1e-2  # the grade moved with them
