"""core/effects/deferral.py: which colour effects a renderer may apply after the CPU's part
of a stack, and that doing so is the stack itself, bit for bit, on a real capture with
its importer's axes and a turned gizmo."""
from __future__ import annotations

from dataclasses import fields, replace

import numpy as np
import pytest

from addon.core.effects import (KINDS, Displace, Explode, Grade, Morph, Reveal, Twist, apply_effect,
                                evaluate_stack, pair)
from addon.core.effects.deferral import Deferred, apply_deferred, drawn_splats, split_stack
from addon.core.effects.morph import aligned
from addon.core.formats import read
from testing.effect_cases import gizmo, grades, reveals

FIELDS = ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")


def not_noise(p) -> bool:
    """A renderer that applies colour effects by height or distance and any morph."""
    if type(p) is Morph:
        return True
    if type(p) is Displace:
        return False
    return "NOISE" not in (getattr(p, "shape", None), getattr(p, "field", None))


def and_displace(p) -> bool:
    """The same renderer applying a displace too."""
    return type(p) is Displace or not_noise(p)


@pytest.fixture(scope="module")
def capture(testdata):
    splats = read(testdata / "guitar.ply")
    assert splats.axes is not None  # the capture's own axes: not an identity scene
    for f in FIELDS:
        getattr(splats, f).flags.writeable = False
    return splats


REVEAL = Reveal(shape="PLANE", progress=0.2, width=0.3, glow_strength=1.0, frame=gizmo())
GRADE = Grade(field="HEIGHT", low=-1.0, high=1.5, frame=gizmo())
DISPLACE = Displace(amplitude=0.1, frequency=2.0)
TWIST = Twist(twist=0.8, frame=gizmo())
NOISY = Reveal(shape="NOISE", progress=0.5, width=0.2, frequency=3.0)
EXPLODE = Explode(fade=0.5)

def morphs(capture):
    """A morph to the capture turned, moved and recoloured (paired in order), and one to
    a third of it (paired along the Morton curve)."""
    c, s = np.cos(0.5), np.sin(0.5)
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]], np.float32)
    other = replace(capture, positions=capture.positions @ turn.T + np.float32(0.2),
                    opacities=np.float32(1.0) - capture.opacities,
                    scales=capture.scales * np.float32(1.4), sh_dc=capture.sh_dc + np.float32(0.3),
                    rotations=capture.rotations[::-1].copy())
    third = capture.subset(np.arange(0, capture.count, 3))
    return (Morph(target=other, pairing=pair(capture.positions, other.positions), amount=0.35),
            Morph(target=third, pairing=pair(capture.positions, third.positions), amount=0.6))


# (stack, the CPU's part, the deferred ones as (params, at_rest))
SPLITS = (
    ((REVEAL, DISPLACE, GRADE), (DISPLACE,), ((REVEAL, True), (GRADE, False))),
    ((GRADE, DISPLACE, REVEAL), (DISPLACE,), ((GRADE, True), (REVEAL, False))),
    ((GRADE, TWIST, DISPLACE), (TWIST, DISPLACE), ((GRADE, True),)),
    ((REVEAL, GRADE), (), ((REVEAL, True), (GRADE, True))),
    # measured between two movers: neither the input's centres nor the final ones
    ((DISPLACE, REVEAL, TWIST), (DISPLACE, REVEAL, TWIST), ()),
    # noise stays on the CPU, and so does everything before it
    ((NOISY, GRADE), (NOISY,), ((GRADE, True),)),
    ((GRADE, NOISY), (GRADE, NOISY), ()),
    # explode writes opacities: nothing before it may be moved past it
    ((REVEAL, EXPLODE), (REVEAL, EXPLODE), ()),
    ((EXPLODE, GRADE), (EXPLODE,), ((GRADE, False),)),
)


# a displace is deferred when nothing before it moves the splats and all after it is deferred
DISPLACE_SPLITS = (
    ((DISPLACE,), (), ((DISPLACE, True),)),
    ((REVEAL, DISPLACE, GRADE), (), ((REVEAL, True), (DISPLACE, True), (GRADE, False))),
    ((GRADE, DISPLACE, REVEAL), (), ((GRADE, True), (DISPLACE, True), (REVEAL, False))),
    # noise before it stays on the CPU: it moves nothing, so the input's centres stay
    ((NOISY, DISPLACE, GRADE), (NOISY,), ((DISPLACE, True), (GRADE, False))),
    # a mover before it, a CPU mover or a CPU colour effect after it
    ((TWIST, DISPLACE, GRADE), (TWIST, DISPLACE), ((GRADE, False),)),
    ((EXPLODE, DISPLACE), (EXPLODE, DISPLACE), ()),
    ((DISPLACE, TWIST), (DISPLACE, TWIST), ()),
    ((DISPLACE, NOISY), (DISPLACE, NOISY), ()),
)


def _morph_splits(capture):
    morph, uneven = morphs(capture)
    off, unpaired = replace(REVEAL, enabled=False), replace(uneven, pairing=None)
    return (
        ((morph,), (), ((morph, False),)),
        ((REVEAL, morph), (REVEAL,), ((morph, False),)),
        ((morph, GRADE), (), ((morph, False), (GRADE, False))),
        # a CPU effect after it reads the morph's output
        ((morph, DISPLACE), (morph, DISPLACE), ()),
        ((morph, DISPLACE, GRADE), (morph, DISPLACE), ((GRADE, False),)),
        # paired along the Morton curve: handed over as its ends, in order
        ((uneven, GRADE), (), ((uneven, False), (GRADE, False))),
        ((uneven, DISPLACE, GRADE), (uneven, DISPLACE), ((GRADE, False),)),
        # its ends are gathered from its source: only the stack's input stays the same
        # arrays from frame to frame (an inactive effect hands its input on)
        ((REVEAL, uneven), (REVEAL, uneven), ()),
        ((off, uneven), (off,), ((uneven, False),)),
        # without a pairing of its own it would pair and gather anew each frame
        ((unpaired,), (unpaired,), ()),
    )


@pytest.mark.parametrize("case", range(10))
def test_a_deferred_morph_is_the_stack_too(capture, case):
    stack, cpu, deferred = _morph_splits(capture)[case]
    test_split_and_then_the_deferred_effects_is_the_stack(capture, stack, cpu, deferred)


@pytest.mark.parametrize("stack, cpu, deferred", DISPLACE_SPLITS)
def test_a_deferred_displace_is_the_stack_too(capture, stack, cpu, deferred):
    test_split_and_then_the_deferred_effects_is_the_stack(capture, stack, cpu, deferred, and_displace)


@pytest.mark.parametrize("stack, cpu, deferred", SPLITS)
def test_split_and_then_the_deferred_effects_is_the_stack(capture, stack, cpu, deferred, taker=not_noise):
    """And the drawn splats (drawn_splats) hold the stack's own centres."""
    got_cpu, got_deferred = split_stack(list(stack), taker)
    assert [id(p) for p in got_cpu] == [id(p) for p in cpu]
    assert got_deferred == tuple(Deferred(p, at_rest) for p, at_rest in deferred)
    want = evaluate_stack(capture, list(stack), 1.3).splats
    part = evaluate_stack(capture, got_cpu, 1.3).splats
    got = apply_deferred(part, capture.positions, got_deferred, 1.3)
    for f in FIELDS:
        a, b = getattr(got, f), getattr(want, f)
        np.testing.assert_array_equal(a.view(np.uint32), b.view(np.uint32), err_msg=f)
    drawn, handed = drawn_splats(part, got_deferred, 1.3)
    np.testing.assert_array_equal(drawn.positions.view(np.uint32), want.positions.view(np.uint32))
    assert handed[1:] == got_deferred[1:] and len(handed) == len(got_deferred)
    if got_deferred and type(got_deferred[0].params) is Morph:
        _check_handed_morph(part, capture.positions, got_deferred[0].params, drawn, handed, want)
    elif any(type(d.params) is Displace for d in got_deferred):
        _check_handed_displace(part, handed, want)
    else:
        assert handed == got_deferred
        for f in set(FIELDS) - {"positions"}:
            assert getattr(drawn, f) is getattr(part, f), f
    if deferred and not any(type(p) in (Reveal, Grade, Morph) for p in cpu):
        for f in ("scales", "sh_dc"):  # the colour the renderer re-uploads was left alone
            assert getattr(part, f) is getattr(capture, f), f


def _check_handed_displace(part, handed, want):
    """A renderer handed a displace adds its layers' blend to the CPU part's centres, which
    are the stack's input (the renderer keeps its copy of them): the stack's centres."""
    from addon.core.effects.displace import noise_layers

    d = next(d for d in handed if type(d.params) is Displace)
    assert d.centres is part.positions  # what the renderer moves: the stack's input
    assert [w for w, _ in d.layers] == [w for w, _ in noise_layers(part.positions, d.params, 1.3)]
    (w0, a), *rest = d.layers
    moved = a * np.float32(w0)
    for w1, b in rest:
        moved += b * np.float32(w1)
    moved *= np.float32(d.params.amount * d.params.amplitude)
    moved += part.positions
    np.testing.assert_array_equal(moved.view(np.uint32), want.positions.view(np.uint32))
    assert all(not d.layers and d.centres is None for d in handed if type(d.params) is not Displace)


def _check_handed_morph(part, rest, p, drawn, handed, want):
    """A renderer handed a morph draws its ends blended in order, then the deferred effects
    after it: bit for bit the stack. Paired in order, the ends are the sets themselves."""
    q = handed[0].params
    assert q.amount == p.amount and q.pairing.in_order and q.target.count == drawn.count
    source_end = aligned(part, p.target, p.pairing).source
    assert handed[0].centres is source_end.positions  # what the renderer blends from
    for f in set(FIELDS) - {"positions"}:
        assert getattr(drawn, f) is getattr(source_end, f), f
        if p.pairing.in_order:
            assert getattr(drawn, f) is getattr(part, f) and getattr(q.target, f) is getattr(p.target, f)
    got = apply_deferred(replace(drawn, positions=source_end.positions), rest, handed, 1.3)
    for f in FIELDS:
        np.testing.assert_array_equal(getattr(got, f).view(np.uint32), getattr(want, f).view(np.uint32),
                                      err_msg=f)


def test_nothing_is_deferred_without_a_taker(capture):
    stack = [REVEAL, DISPLACE, GRADE]
    assert split_stack(stack, lambda p: False) == (stack, ())


def _kinds_params():
    yield from reveals()
    yield from grades()
    for amplitude in (0.0, 0.1):
        yield Displace(amplitude=amplitude, frame=gizmo())
    for fade, spin in ((0.0, 0.0), (0.5, 2.0)):
        yield Explode(fade=fade, spin=spin, frame=gizmo())
    yield Twist(twist=0.8, frame=gizmo())


def test_each_kind_writes_only_what_it_declares(capture):
    """EffectKind.writes is an upper bound: every other field comes back as the very
    input array (split_stack moves effects past kinds by it)."""
    for p in _kinds_params():
        kind = next(k for k in KINDS.values() if type(p) is k.params)
        out = apply_effect(capture, p, 1.1, capture.positions)
        for f in set(FIELDS) - kind.writes:
            assert getattr(out, f) is getattr(capture, f), (kind.id, f)


def test_geometry_kinds_read_no_colour(capture):
    """split_stack lets a colour effect pass a kind writing only positions and rotations,
    on the promise that such a kind reads nothing else: new colour in, same centres out."""
    recoloured = replace(capture, opacities=capture.opacities * np.float32(0.5),
                         scales=capture.scales * np.float32(2.0), sh_dc=-capture.sh_dc)
    geometry = [k for k in KINDS.values() if k.writes <= {"positions", "rotations"}]
    assert {k.id for k in geometry} >= {"DISPLACE", "TWIST"}
    for p in (DISPLACE, TWIST):
        a = apply_effect(capture, p, 0.7, capture.positions)
        b = apply_effect(recoloured, p, 0.7, recoloured.positions)
        for f in ("positions", "rotations"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
    assert all(f.name != "writes" for f in fields(REVEAL))  # a kind's, not a params' field
