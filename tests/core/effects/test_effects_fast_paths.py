"""The effects' fast paths pinned to the readable kernels they replace (effects_reference:
the kernels of 09da160), on a real capture with a real gizmo frame, across each effect's
parameters: memoized fields, slerp setups and noise lattices, the streamlined grade and
the two-thread block loops must give the same splats bit for bit, except the noise
lattice's weighted sum, which is held to the bound derived in its test.

The capture (guitar.ply) is tiled four times, shifted, so that a kernel has several blocks
of common.BLOCK rows and the two-thread path runs.
"""
from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest

from testing import effects_reference as ref
from testing.effect_cases import FRAMES, gizmo, grades, reveals, varied
from addon.core.effects import (Displace, Explode, Grade, Morph, Reveal, Twist, apply_effect,
                                common, evaluate_stack, noise)
from addon.core.effects import morph, recycle
from addon.core.effects.lattice import LATTICES
from addon.core.effects.morph import SLERPS, slerp
from addon.core.formats import read
from addon.core.reframe import map_into
from addon.core.splats import SplatSet

FIELDS = ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")


def frozen(s: SplatSet) -> SplatSet:
    for f in FIELDS:
        getattr(s, f).flags.writeable = False  # a kernel that writes its input fails here
    return s


def tiled(one: SplatSet, copies=4) -> SplatSet:
    extent = float(np.ptp(one.positions[:, 0])) + 0.1
    parts = [one.positions + np.array([k * extent, 0.0, 0.0], np.float32) for k in range(copies)]
    return frozen(SplatSet(np.concatenate(parts), *(np.concatenate([getattr(one, f)] * copies)
                                                   for f in FIELDS[1:]), axes=one.axes))


@pytest.fixture(scope="module")
def capture(testdata):
    splats = tiled(read(testdata / "guitar.ply"))
    assert splats.count > 4 * common.BLOCK
    return splats


def assert_bits(a: np.ndarray, b: np.ndarray, what: str = "") -> None:
    """The same float32 bits (signs of zero and NaNs included)."""
    assert a.shape == b.shape and a.dtype == b.dtype == np.float32, what
    np.testing.assert_array_equal(a.view(np.uint32), b.view(np.uint32), err_msg=what)


def assert_same(got: SplatSet, want: SplatSet, base: SplatSet) -> None:
    """The same bits (signs of zero and NaNs included), and the same arrays passed through
    unchanged (copy-on-write)."""
    for f in FIELDS:
        a, b = getattr(got, f), getattr(want, f)
        assert (a is getattr(base, f)) == (b is getattr(base, f)), f"{f}: passed through differs"
        assert_bits(a, b, f)


@pytest.mark.parametrize("threads", (1, 2))
def test_reveal_and_grade_match_the_reference(capture, monkeypatch, threads):
    """At the top of a stack (rest given: the memoized field) and on splats the stack has
    moved (rest None: measured block by block)."""
    monkeypatch.setattr(common, "THREADS", threads)
    for p, rest in itertools.product(itertools.chain(reveals(), grades()),
                                     (capture.positions, None)):
        kernel = ref.reveal if isinstance(p, Reveal) else ref.grade
        assert_same(apply_effect(capture, p, 0.0, rest), kernel(capture, p, 0.0, rest), capture)


@pytest.mark.parametrize("threads", (1, 2))
def test_displace_matches_the_reference(capture, monkeypatch, threads):
    """Times on a layer (one layer, w1 = 0) and between two, either speed sign."""
    monkeypatch.setattr(common, "THREADS", threads)
    for time, speed, amplitude, frequency, seed, frame in varied(
            ((0.0, 1.0, 1.37, 4.2), (0.5, -1.3)), ((0.1, -0.4), (0.7, 3.0), (0, 5), FRAMES)):
        p = Displace(amplitude=amplitude, frequency=frequency, speed=speed, seed=seed,
                     amount=0.8, frame=frame)
        got = apply_effect(capture, p, time, capture.positions)
        assert_same(got, ref.displace(capture, p, time, capture.positions), capture)


def test_noise_lattice_matches_value_noise(capture):
    """Every seed/channel/layer field from the memoized lattice against value_noise.

    The two sum the same 8 float32 products w_k c_k in different orders. Each order's
    rounding error is at most 7 u sum|w_k c_k| (u = 2^-24, 7 additions), and
    sum|w_k c_k| <= sum w_k = 1 up to rounding since |c_k| <= 1, so the two differ by at
    most 14 u ~ 8.3e-7."""
    bound = 14 * 2.0 ** -24 * 1.0001
    worst = 0.0
    for frame, frequency in itertools.product(FRAMES, (0.37, 2.0, 11.0)):
        LATTICES.clear()
        for seed, channels, layer in ((0, 1, 0), (3, 3, 0), (3, 3, -2), (9, 3, 7)):
            got = noise.evaluate_field(capture.positions, frame, frequency, seed, channels, layer)
            want = noise.reference_field(capture.positions, frame, frequency, seed, channels,
                                         layer)
            for a, b in zip(got, want):
                worst = max(worst, float(np.abs(a - b).max()))
                assert np.abs(a - b).max() <= bound
    assert worst > 0.0  # the bound is exercised: the fast sum is a different one


def test_memoized_noise_is_the_memo_of_evaluate_field(capture):
    """field/field_rows (memoized, (N, channels)) hold exactly evaluate_field's values."""
    noise.FIELDS.clear()
    rows = noise.field_rows(capture.positions, gizmo(), 2.0, 1, 3, 4)
    assert rows.shape == (capture.count, 3) and not rows.flags.writeable
    assert noise.field_rows(capture.positions, gizmo(), 2.0, 1, 3, 4) is rows
    for a, b in zip(noise.field(capture.positions, gizmo(), 2.0, 1, 3, 4),
                    noise.evaluate_field(capture.positions, gizmo(), 2.0, 1, 3, 4)):
        np.testing.assert_array_equal(a, b)


def target_of(capture) -> SplatSet:
    """The capture turned and moved: another pose of real rotations."""
    m = gizmo()
    m[:3, :3] /= np.cbrt(np.linalg.det(m[:3, :3]))
    return frozen(map_into(capture, m))


def with_sh_rest(capture, testdata) -> SplatSet:
    """The capture at degree 3: test64.ply's real SH coefficients, repeated over its splats
    (guitar.ply has none), so the lerp of sh_rest has data to blend."""
    rest = read(testdata / "test64.ply").sh_rest
    return frozen(replace(capture, sh_rest=np.resize(rest, (capture.count,) + rest.shape[1:])))


@pytest.mark.parametrize("threads", (1, 2))
@pytest.mark.parametrize("recycled", (False, True))
@pytest.mark.parametrize("block_bytes", (morph.LERP_BYTES, 4096))
def test_slerp_and_morph_match_the_reference(capture, testdata, monkeypatch, threads, recycled,
                                             block_bytes):
    """Memoized setup, per-block weights: nearly equal pairs (nlerp), opposite hemispheres
    and general pairs, at amounts across (0, 1), repeated (the memo's hit). Recycled: every
    lerp's output in a recycle.Recycler buffer (as sh_rest is from 32 MB on), reused from
    the third amount on (the previous result is still held); else all fresh arrays. Small blocks: every
    array's lerp in many blocks (on two threads too), not only sh_rest's."""
    monkeypatch.setattr(common, "THREADS", threads)
    monkeypatch.setattr(morph, "LERP_BYTES", block_bytes)
    monkeypatch.setattr(recycle, "MIN_BYTES", 0 if recycled else 1 << 62)  # else: np.empty
    monkeypatch.setattr(morph, "BUFFERS", recycle.Recycler(size=16))
    source = with_sh_rest(capture, testdata)
    target = target_of(source)
    assert source.sh_degree == 3 and not np.array_equal(source.sh_rest, target.sh_rest)
    q1 = target.rotations.copy()
    q1[:1000] = source.rotations[:1000]           # the same rotation: nlerp
    q1[1000:2000] = -source.rotations[1000:2000]  # the same, other hemisphere
    later = slice(3 * common.BLOCK - 200, 3 * common.BLOCK + 300)  # nlerp across blocks
    q1[later] = source.rotations[later]
    SLERPS.clear()
    for t in (0.0, 1e-4, 0.25, 0.5, 0.77, 0.999, 0.25):
        assert_bits(slerp(source.rotations, q1, t), ref.slerp(source.rotations, q1, t))
    bases = set()
    for amount in (0.1, 0.5, 0.9, 0.3):
        got = evaluate_stack(source, [Morph(target=target, amount=amount)], 0.0).splats
        bases.add(id(got.sh_rest.base))
        assert_bits(got.rotations, ref.slerp(source.rotations, target.rotations, amount))
        for f in ("positions", "scales", "opacities", "sh_dc", "sh_rest"):
            a, b = getattr(source, f), getattr(target, f)
            assert_bits(getattr(got, f), a + (b - a) * np.float32(amount))
    assert len(bases) == 2 if recycled else bases == {id(None)}


def test_two_threads_give_the_one_thread_splats(capture, monkeypatch):
    """Every kernel that runs its blocks on two threads, against the same kernel on one."""
    effects = [Twist(twist=0.8, swirl=1.2, frame=gizmo()),
               Explode(spin=2.0, gravity=1.0, fade=0.3, frame=gizmo()),
               Explode(mode="DIRECTION", strength=2.0, frame=gizmo()),
               Reveal(progress=0.2, width=0.4, glow_strength=1.0),
               Displace(amplitude=0.2, frequency=2.0), Grade(field="DISTANCE")]
    for stack in [effects[:1], effects[1:2], effects[2:3], effects]:
        monkeypatch.setattr(common, "THREADS", 1)
        one = evaluate_stack(capture, stack, 1.3).splats
        monkeypatch.setattr(common, "THREADS", 2)
        two = evaluate_stack(capture, stack, 1.3).splats
        assert_same(two, one, capture)


def test_memos_follow_the_positions_array(capture):
    """A memoized field belongs to one positions array: new centres with equal values
    but another array, or other values, are measured again, never served stale."""
    p = Reveal(progress=0.0, width=0.5)
    first = evaluate_stack(capture, [p], 0.0).splats
    moved = frozen(SplatSet(capture.positions + np.float32(0.25), *(getattr(capture, f)
                                                                    for f in FIELDS[1:]),
                            axes=capture.axes))
    got = evaluate_stack(moved, [p], 0.0).splats
    assert_same(got, ref.reveal(moved, p, 0.0, moved.positions), moved)
    assert not np.array_equal(got.opacities, first.opacities)


def test_blocks_run_once_each_and_nested_loops_finish(monkeypatch):
    """for_blocks covers every row once on two threads, passes a block's error on, and a
    loop started from inside a block (on the helper thread too) runs instead of waiting."""
    import threading
    monkeypatch.setattr(common, "THREADS", 2)
    n = 9 * 1000 + 7
    seen = np.zeros(n, np.int64)
    inner = np.zeros(n, np.int64)

    def block(part):
        seen[part] += 1
        common.for_blocks(part.stop - part.start, lambda p: np.add.at(
            inner, np.arange(part.start + p.start, part.start + p.stop), 1), 100)

    done = threading.Event()
    threading.Thread(target=lambda: (common.for_blocks(n, block, 1000), done.set()),
                     daemon=True).start()
    assert done.wait(60), "for_blocks did not return"
    assert (seen == 1).all() and (inner == 1).all()

    def fails(part):
        if part.start == 5000:
            raise ValueError("block 5")
    with pytest.raises(ValueError, match="block 5"):
        common.for_blocks(n, fails, 1000)
