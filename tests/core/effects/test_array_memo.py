"""core/effects/array_memo: the one memo the effects' per-array caches share (noise lattices
and values, height fields, slerp setups)."""
from __future__ import annotations

import gc

import numpy as np

from addon.core.effects.array_memo import ArrayMemo


def test_a_hit_needs_the_same_arrays_and_the_same_extra():
    memo, calls = ArrayMemo(4), []
    a, b = np.zeros(3), np.ones(3)

    def compute(tag):
        calls.append(tag)
        return tag

    assert memo.get((a,), (1,), lambda: compute("a1")) == "a1"
    assert memo.get((a,), (1,), lambda: compute("again")) == "a1"
    assert memo.get((a,), (2,), lambda: compute("a2")) == "a2"
    assert memo.get((b,), (1,), lambda: compute("b1")) == "b1"
    assert memo.get((a, b), (), lambda: compute("ab")) == "ab"
    assert memo.get((b, a), (), lambda: compute("ba")) == "ba"  # order is part of the key
    assert calls == ["a1", "a2", "b1", "ab", "ba"]


def test_an_entry_goes_with_its_arrays_and_a_reused_id_never_hits():
    memo = ArrayMemo(8)
    a = np.zeros(1000)
    memo.get((a,), (), lambda: "old")
    old_id = id(a)
    del a
    gc.collect()
    fresh = [np.zeros(1000) for _ in range(50)]  # one of them may take the old id
    reused = [array for array in fresh if id(array) == old_id]
    for array in reused + fresh:
        assert memo.get((array,), (), lambda: "new") == "new"
    assert len(memo.entries) <= 8


def test_only_the_newest_entries_are_kept():
    memo = ArrayMemo(2)
    arrays = [np.zeros(2) for _ in range(3)]
    for i, array in enumerate(arrays):
        memo.get((array,), (), lambda i=i: i)
    assert memo.get((arrays[0],), (), lambda: "recomputed") == "recomputed"
    assert memo.get((arrays[2],), (), lambda: "recomputed") == 2
