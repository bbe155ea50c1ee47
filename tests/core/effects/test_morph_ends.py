"""core/effects/morph.py's ends (aligned): a morph between sets of any sizes is the in-order
blend of two sets gathered once, in the larger set's order, on a real capture with its
importer's axes morphing into a third of itself turned and moved."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from addon.core.effects import Morph, Reveal, evaluate_stack, pair
from addon.core.effects.morph import ALIGNED, aligned, blend
from addon.core.formats import read
from addon.core.reframe import map_into
from testing.effect_cases import gizmo

FIELDS = ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")


@pytest.fixture(scope="module")
def capture(testdata):
    splats = read(testdata / "guitar.ply")
    assert splats.axes is not None and splats.sh_degree == 0
    return splats


@pytest.fixture(scope="module")
def third(capture, testdata):
    """Every third splat of the capture, turned and moved, at degree 3 (test64.ply's SH)."""
    m = gizmo()
    m[:3, :3] /= np.cbrt(np.linalg.det(m[:3, :3]))
    part = map_into(capture.subset(np.arange(0, capture.count, 3)), m)
    rest = read(testdata / "test64.ply").sh_rest
    return replace(part, sh_rest=np.resize(rest, (part.count,) + rest.shape[1:]))


def _bits(a, b, what):
    np.testing.assert_array_equal(np.asarray(a).view(np.uint32), np.asarray(b).view(np.uint32), err_msg=what)


@pytest.mark.parametrize("larger", ("source", "target"))
def test_the_ends_put_each_pair_at_the_larger_sets_index(capture, third, larger):
    source, target = (capture, third) if larger == "source" else (third, capture)
    pairing = pair(source.positions, target.positions)
    ends = aligned(source, target, pairing)
    a, b = ends.source, ends.target
    count = max(source.count, target.count)
    assert a.count == b.count == count and ends.pairing.in_order
    assert a.sh_rest.shape[1] == b.sh_rest.shape[1] == 15  # the lower degree zero-padded
    # the larger set is its own end, in its own order
    big, at, lone = (a, pairing.source, pairing.source_only) if larger == "source" else \
        (b, pairing.target, pairing.target_only)
    small_end = b if larger == "source" else a
    for f in FIELDS[:-1]:
        _bits(getattr(big, f), getattr(source if larger == "source" else target, f), f)
    # each smaller-set splat at its partner's index
    for f in FIELDS[:-1]:
        _bits(getattr(small_end, f)[at], getattr(target if larger == "source" else source, f)[
            pairing.target if larger == "source" else pairing.source], f)
    # a splat without a partner has itself, transparent, as its other end
    assert len(lone) == count - min(source.count, target.count) > 0
    for f in ("positions", "scales", "rotations", "sh_dc"):
        _bits(getattr(small_end, f)[lone], getattr(big, f)[lone], f)
    assert (small_end.opacities[lone] == 0.0).all()
    _bits(small_end.sh_rest[lone], big.sh_rest[lone], "sh_rest")
    # gathered once: the memo hands out the same read-only arrays
    again = aligned(source, target, pairing)
    for f in FIELDS:
        assert getattr(again.source, f) is getattr(a, f) and getattr(again.target, f) is getattr(b, f)
        assert not getattr(small_end, f).flags.writeable


@pytest.mark.parametrize("larger", ("source", "target"))
@pytest.mark.parametrize("t", (0.3, 0.85))
def test_a_morph_of_any_sizes_is_the_in_order_blend_of_its_ends(capture, third, larger, t):
    """Bit for bit: what a renderer handed the ends in order draws is the kernel's result;
    and the lone splats fade in place (their centres stay, their opacity scales)."""
    source, target = (capture, third) if larger == "source" else (third, capture)
    pairing = pair(source.positions, target.positions)
    got = evaluate_stack(source, [Morph(target=target, pairing=pairing, amount=t)], 0.0).splats
    ends = aligned(source, target, pairing)
    again = blend(ends.source, ends.target, ends.pairing, t)
    for f in FIELDS:
        _bits(getattr(again, f), getattr(got, f), f)
    lone, own, keep = ((pairing.source_only, source, 1.0 - t) if larger == "source"
                       else (pairing.target_only, target, t))
    _bits(got.positions[lone], own.positions[lone], "lone centres")
    # o + (0 - o) t in float32: o t rounded, then the sum, then t itself as a float32
    o = own.opacities[lone].astype(np.float64)
    bar = o * 2.0 ** -24 * (t + (1.0 - t) + 0.5) * 1.001
    assert (np.abs(got.opacities[lone] - o * keep) <= bar).all()


def test_noise_after_a_morph_to_fewer_splats_stays_on_the_source_splats(capture, third):
    """The output keeps the source's order, so a noise dissolve after the morph is measured
    at each splat's own rest centre: at a small amount it is the dissolve of the source."""
    dissolve = Reveal(shape="NOISE", progress=0.5, width=0.2, frequency=3.0)
    morph = Morph(target=third, pairing=pair(capture.positions, third.positions), amount=1e-3)
    after = evaluate_stack(capture, [morph, dissolve], 0.0).splats
    alone = evaluate_stack(capture, [dissolve], 0.0).splats
    assert np.ptp(alone.opacities) > 0.5  # the dissolve shows
    np.testing.assert_allclose(after.opacities, alone.opacities, atol=2e-3)


def test_empty_ends_fade_the_other_set_in_or_out(capture):
    empty = capture.subset(np.zeros(0, np.int64))
    for source, target in ((empty, capture), (capture, empty)):
        ends = aligned(source, target, pair(source.positions, target.positions))
        assert ends.source.count == ends.target.count == capture.count
        fading = ends.source if source is empty else ends.target
        assert (fading.opacities == 0.0).all()
        _bits(fading.positions, capture.positions, "positions")


def test_the_memo_lets_go_of_ends_whose_inputs_are_gone(capture):
    """Its values hold only the arrays it made: dropping the inputs drops the entry."""
    import gc

    ALIGNED.clear()
    source = capture.subset(np.arange(0, capture.count, 2))
    ends = aligned(source, capture, pair(source.positions, capture.positions))
    assert len(ALIGNED.entries) == 1
    del source, ends
    gc.collect()
    aligned(capture, capture, pair(capture.positions, capture.positions))
    assert len(ALIGNED.entries) == 1
