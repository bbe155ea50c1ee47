"""core/percentile.py gives np.percentile's values bit for bit, found from a bracket of
the order statistics instead of a partition of the whole array, and falls back to
np.percentile where its bracket misses."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core import framing, percentile
from addon.core.percentile import percentiles

QS = (0.0, 2.0, 25.0, 50.0, 97.5, 98.0, 100.0)


def _arrays():
    rng = np.random.default_rng(7)
    n = 200_003
    yield "normal", rng.normal(size=n)
    yield "heavy tails", rng.standard_cauchy(n)
    yield "few values (ties)", rng.integers(0, 5, n).astype(np.float64)
    yield "sorted", np.sort(rng.uniform(-3, 3, n))
    yield "floaters", np.concatenate([rng.normal(size=n), rng.normal(0, 1e4, 5000)])
    yield "float32 centres", rng.normal(size=n).astype(np.float32).astype(np.float64) * 1e-3 + 12.5
    yield "one value", np.full(n, 0.25)
    yield "just over the minimum size", rng.normal(size=percentile.SELECT_MIN + 1)


@pytest.mark.parametrize("name, values", list(_arrays()), ids=[a[0] for a in _arrays()])
def test_percentiles_are_numpys_bit_for_bit(name, values):
    assert percentiles(values, QS) == [float(v) for v in np.percentile(values, QS)]


def test_a_bracket_that_misses_falls_back_to_numpy(monkeypatch):
    """A sample that says nothing of the array (its every element the same) gives brackets
    that hold no rank: the result is still np.percentile's, through its own partition."""
    rng = np.random.default_rng(3)
    values = rng.normal(size=300_000)
    values[::len(values) // percentile.SAMPLES] = 0.0  # exactly the sampled elements
    calls = []
    original = np.percentile
    monkeypatch.setattr(np, "percentile", lambda *a, **k: calls.append(1) or original(*a, **k))
    got = percentiles(values, (2.0, 98.0))
    assert calls, "the bracket round 0 should have missed the 2% and 98% ranks"
    monkeypatch.undo()
    assert got == [float(v) for v in np.percentile(values, (2.0, 98.0))]


def test_robust_bounds_are_numpys_percentile_box():
    rng = np.random.default_rng(11)
    pts = rng.normal(size=(150_000, 3)) * (1.0, 3.0, 0.2) + (0.5, -2.0, 7.0)
    pts[::997, 1] = np.nan
    pts[5, 2] = np.inf
    bounds = framing.robust_bounds(pts)
    finite = pts[np.isfinite(pts).all(axis=1)]
    lo, hi = np.percentile(finite, [framing.LOW_PERCENTILE, framing.HIGH_PERCENTILE], axis=0)
    assert np.array_equal(bounds.low, lo) and np.array_equal(bounds.high, hi)
    assert np.array_equal(bounds.centre, (lo + hi) / 2.0)
    with pytest.raises(ValueError, match="no finite"):
        framing.robust_bounds(np.full((4, 3), np.nan))
