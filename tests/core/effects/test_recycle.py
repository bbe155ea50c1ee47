"""recycle.Recycler: a kept buffer is handed out again only when nothing refers to what it
handed out before (no array, slice, view of a view, memoryview or weak reference), so a
caller never sees data it holds change; and a morph scrubbed while the viewport holds the
previous frame keeps that frame's splats."""
from __future__ import annotations

import gc
import weakref

import numpy as np
import pytest

from addon.core.effects import Morph, evaluate_stack, morph, recycle
from testing.synth import random_splats

SHAPE = (1000, 15, 3)


@pytest.fixture
def pool(monkeypatch):
    monkeypatch.setattr(recycle, "MIN_BYTES", 0)
    return recycle.Recycler(size=2)


def test_a_buffer_nothing_holds_is_handed_out_again(pool):
    first = pool.empty(SHAPE)
    base = id(first.base)
    first.flags.writeable = False  # frozen by its last holder: writeable again when reused
    del first
    again = pool.empty(SHAPE)
    assert id(again.base) == base and again.flags.writeable and again.flags.c_contiguous
    assert again.shape == SHAPE and again.dtype == np.float32


@pytest.mark.parametrize("hold", ("array", "slice", "view of view", "memoryview", "reshaped"))
def test_a_buffer_still_referred_to_is_not_reused(pool, hold):
    first = pool.empty(SHAPE)
    first[...] = 7.0
    keep = {"array": lambda a: a, "slice": lambda a: a[10:20],
            "view of view": lambda a: a[5:][1:, 2],
            "memoryview": memoryview,
            "reshaped": lambda a: a.reshape(-1, 45)}[hold](first)
    base = id(first.base)
    del first
    gc.collect()
    other = pool.empty(SHAPE)
    assert id(other.base) != base
    other[...] = -1.0
    assert (np.asarray(keep) == 7.0).all()


def test_weak_references_cannot_reach_a_reused_buffer(pool):
    """A memo keyed weakly by a handed-out array (as the noise memos key positions) sees it
    die before its buffer is reused; one holding the buffer itself weakly keeps it kept."""
    first = pool.empty(SHAPE)
    ref, base = weakref.ref(first), id(first.base)
    del first
    again = pool.empty(SHAPE)
    assert ref() is None and id(again.base) == base
    buffer_ref = weakref.ref(again.base)
    del again
    assert id(pool.empty(SHAPE).base) != base and buffer_ref() is not None


def test_other_shapes_and_small_arrays_get_their_own(pool, monkeypatch):
    first = pool.empty(SHAPE)
    base = id(first.base)
    del first
    assert id(pool.empty((999, 15, 3)).base) != base
    assert pool.empty(SHAPE, np.float64).dtype == np.float64
    monkeypatch.setattr(recycle, "MIN_BYTES", 1 << 30)
    assert pool.empty(SHAPE).base is None
    assert len(pool.buffers) <= pool.size
    pool.clear()
    assert not pool.buffers


def test_scrubbing_a_morph_keeps_the_frames_it_handed_out(monkeypatch):
    """Frames held (as the viewport holds the one it draws) keep their values while later
    frames are evaluated into recycled buffers."""
    monkeypatch.setattr(recycle, "MIN_BYTES", 0)
    monkeypatch.setattr(morph, "BUFFERS", recycle.Recycler(size=16))
    source, target = random_splats(5000, 3, 1), random_splats(5000, 3, 2)

    def frame(t):
        return evaluate_stack(source, [Morph(target=target, amount=t)], 0.0).splats

    held = [(t, frame(t)) for t in (0.2, 0.4)]
    bases = set()
    for t in (0.6, 0.8, 0.3, 0.7):
        out = frame(t)
        bases.add(id(out.sh_rest.base))
        want = source.sh_rest + (target.sh_rest - source.sh_rest) * np.float32(t)
        np.testing.assert_array_equal(out.sh_rest, want)
        del out
    assert len(bases) == 1  # every one after the held frames went into the same buffer
    for t, splats in held:
        want = source.sh_rest + (target.sh_rest - source.sh_rest) * np.float32(t)
        np.testing.assert_array_equal(splats.sh_rest, want)
