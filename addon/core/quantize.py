"""Codebooks for the SOG writer: a 1D codebook (256 values) and a seeded k-means palette.

Both are deterministic (fixed seed, no global random state), so writing the same set twice
gives the same bytes. Both assign every value to its *nearest* entry, so a decoded value's
error is exactly its distance to the codebook, which is what the round-trip tests check.
"""
from __future__ import annotations

import numpy as np

CHUNK_ELEMS = 1 << 24   # distance-matrix elements per assignment block (64 MB of float32)
FLAT_MAX_K = 4096       # above this a flat assignment costs N x k distances: split in two levels
COARSE_K = 256


def nearest_1d(values: np.ndarray, codebook: np.ndarray) -> np.ndarray:
    """Index of the nearest entry of an ascending codebook, for every value."""
    mids = (codebook[1:] + codebook[:-1]) * 0.5
    return np.searchsorted(mids, values, side="left").astype(np.uint8 if len(codebook) <= 256 else np.int64)


def codebook_1d(values: np.ndarray, k: int = 256, iterations: int = 30) -> np.ndarray:
    """k ascending float32 values minimising the squared error of `values` (finite ones):
    Lloyd's algorithm on sorted data, where a cluster is a contiguous run, so an iteration
    costs k binary searches over prefix sums instead of a pass over the data.

    Seeded on a blend of quantiles and an even spread over the range: pure quantiles leave
    the sparse tails (large scales, bright colours) one coarse entry between them."""
    v = np.sort(np.asarray(values, np.float64).ravel())
    v = v[np.isfinite(v)]
    if v.size == 0:
        return np.zeros(k, np.float32)
    uniq = np.unique(v)
    if len(uniq) <= k:  # every value gets its own entry: lossless
        return np.concatenate([uniq, np.repeat(uniq[-1:], k - len(uniq))]).astype(np.float32)
    prefix = np.concatenate([[0.0], np.cumsum(v)])
    t = (np.arange(k) + 0.5) / k
    c = np.unique(0.5 * np.quantile(v, t) + 0.5 * (v[0] + t * (v[-1] - v[0])))
    for _ in range(iterations):
        cuts = np.concatenate([[0], np.searchsorted(v, (c[1:] + c[:-1]) * 0.5), [len(v)]])
        count = np.diff(cuts)
        keep = count > 0
        new = (prefix[cuts[1:]] - prefix[cuts[:-1]])[keep] / count[keep]
        if len(new) == len(c) and np.allclose(new, c, rtol=0, atol=1e-12):
            break
        c = new
    c = _fill_gaps(c, uniq, k)
    return np.sort(c).astype(np.float32)


def _fill_gaps(c: np.ndarray, uniq: np.ndarray, k: int) -> np.ndarray:
    """Spend entries lost to empty clusters on the values farthest from the codebook."""
    c = np.unique(c)
    while len(c) < k:
        err = np.abs(uniq - c[np.clip(nearest_1d(uniq, c).astype(np.int64), 0, len(c) - 1)])
        worst = np.argsort(err)[::-1][: k - len(c)]
        extra = np.setdiff1d(uniq[worst], c)
        if extra.size == 0:
            break
        c = np.unique(np.concatenate([c, extra]))
    return np.concatenate([c, np.repeat(c[-1:], k - len(c))])


def assign(points: np.ndarray, centroids: np.ndarray) -> np.ndarray:
    """Nearest centroid per point, by argmin of |c|^2 - 2 p.c (|p|^2 is the same for every
    centroid of a point), in blocks that bound the distance matrix's memory."""
    c = np.ascontiguousarray(centroids, np.float32)
    c2 = np.einsum("ij,ij->i", c, c)
    out = np.empty(len(points), np.int64)
    step = max(1, CHUNK_ELEMS // max(1, len(c)))
    for lo in range(0, len(points), step):
        d = points[lo:lo + step] @ c.T
        d *= -2.0
        d += c2
        out[lo:lo + step] = np.argmin(d, axis=1)
    return out


def _means(points, labels, old):
    """Centroid of each cluster; an empty one keeps its old position."""
    k = len(old)
    count = np.bincount(labels, minlength=k)
    sums = np.stack([np.bincount(labels, points[:, j], minlength=k) for j in range(points.shape[1])], 1)
    return np.where(count[:, None] > 0, sums / np.maximum(count, 1)[:, None], old).astype(np.float32)


def kmeans(points: np.ndarray, k: int, iterations: int = 10, seed: int = 0,
           sample: int = 65536) -> tuple[np.ndarray, np.ndarray]:
    """(centroids (k', D) float32, labels (N,)) with k' = min(k, N). Lloyd iterations run on
    a seeded random sample (at least 4 points per centroid), then every point is assigned
    once and the centroids moved to the means of their final members."""
    x = np.ascontiguousarray(points, np.float32)
    n = len(x)
    if n <= k:  # each point is its own centroid, as splat-transform does
        return x.copy(), np.arange(n)
    if k > FLAT_MAX_K:
        return _two_level(x, k, iterations, seed, sample)
    rng = np.random.default_rng(seed)
    m = min(n, max(sample, 4 * k))
    fit = x[np.sort(rng.choice(n, m, replace=False))] if m < n else x
    cen = fit[np.sort(rng.choice(len(fit), k, replace=False))].copy()
    for _ in range(iterations):
        cen = _means(fit, assign(fit, cen), cen)
    labels = assign(x, cen)
    return _means(x, labels, cen), labels


def _two_level(x, k, iterations, seed, sample):
    """k-means for a large palette (SOG's 64K entries): COARSE_K clusters, then each one
    split into entries in proportion to its size. Costs N x (COARSE_K + k / COARSE_K)
    distances instead of N x k, for a slightly worse palette than a flat k-means."""
    coarse, top = kmeans(x, COARSE_K, iterations, seed, sample)
    sizes = np.bincount(top, minlength=len(coarse))
    share = np.maximum(1, np.floor(k * sizes / len(x))).astype(np.int64) * (sizes > 0)
    share = np.minimum(share, sizes)
    cents, labels, base = [], np.empty(len(x), np.int64), 0
    for group in np.flatnonzero(sizes):
        rows = np.flatnonzero(top == group)
        cen, lab = kmeans(x[rows], int(share[group]), iterations, seed + 1 + int(group), sample)
        cents.append(cen)
        labels[rows] = lab + base
        base += len(cen)
    return np.concatenate(cents), labels
