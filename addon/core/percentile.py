"""np.percentile (its default, linear method) of a large 1-D array from the few values it needs.

A percentile needs two order statistics, the values of ranks floor(v) and floor(v) + 1 at
its virtual index v; np.percentile finds them by partitioning the whole array, which for a
million centres and two percentiles is about 15 ms a column. Here a strided sample brackets
each pair of ranks, one pass counts the values below the bracket and keeps those inside it
(about 4% of the array), and only those are partitioned. Where the bracket misses a rank
(a sample that happens to be unrepresentative), np.percentile itself runs: the result is
always np.percentile's, bit for bit (tests/core/test_percentile.py pins it).
"""
from __future__ import annotations

import math

import numpy as np

SELECT_MIN = 1 << 16   # below this, np.percentile's own partition is as fast
SAMPLES = 4096         # the sample's size
MARGIN = 0.01          # the bracket: the sample's quantiles at q -/+ this (4.5 sigma at q = 2%)


def percentiles(values: np.ndarray, qs) -> list[float]:
    """np.percentile(values, qs) of a 1-D float array without NaN, as a list."""
    values = np.asarray(values)
    n = values.size
    if n < SELECT_MIN or values.ndim != 1:
        return [float(v) for v in np.percentile(values, qs)]
    sample = np.sort(values[::n // SAMPLES])
    out = []
    for q in np.true_divide(np.asarray(qs, np.float64), 100):
        index = _virtual_index(n, q)
        below = math.floor(index)
        pair = _order_statistics(values, sample, q, (below, min(below + 1, n - 1)))
        if pair is None:
            return [float(v) for v in np.percentile(values, qs)]
        out.append(_lerp(pair[0], pair[1], index - below))
    return out


def _virtual_index(n: int, q: float) -> float:
    """numpy's virtual index of the linear method (alpha = beta = 1), as it computes it."""
    return float(np.float64(n) * q + (1.0 + q * (1.0 - 1.0 - 1.0)) - 1)


def _lerp(a: float, b: float, t: float) -> float:
    """numpy's interpolation between the order statistics: from the nearer end, so that
    t = 1 gives b exactly."""
    a, b, t = np.float64(a), np.float64(b), np.float64(t)
    diff = b - a
    return float(b - diff * (1 - t) if t >= 0.5 else a + diff * t)


def _order_statistics(values, sample, q: float, ranks) -> tuple | None:
    """The values of `ranks` (sorted order) from the values inside the sample's bracket
    round quantile q; None where the bracket does not hold both ranks."""
    last = len(sample) - 1
    low = sample[max(0, math.floor((q - MARGIN) * last))]
    high = sample[min(last, math.ceil((q + MARGIN) * last))]
    inside = values[(values >= low) & (values <= high)]
    start = int(np.count_nonzero(values < low))
    first, second = ranks[0] - start, ranks[1] - start
    if first < 0 or second >= len(inside):
        return None
    picked = np.partition(inside, (first, second))
    return picked[first], picked[second]
