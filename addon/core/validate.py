"""Count and handle bad values in a decoded SplatSet: NaN/Inf values, all-zero quaternions
and scales that are not positive (a .splat stores linear scales, which can be negative or
zero; a PLY log scale below -103 underflows to 0).

Garbage must never reach a renderer silently. Each reader's output goes through
`check_values`, which counts the bad splats and then, by policy:
  "fix"   neutralise them in place: a splat with any non-finite value gets finite
          zeros there and opacity 0 (invisible, but the count and index order stay,
          which sequences and morphs rely on); a zero quaternion becomes the
          identity, which is how INRIA's normalize-then-build-matrix path draws it;
          a scale s <= 0 becomes max(|s|, TINY_SCALE): Sigma = R S S^T R^T depends on
          s^2 only, so |s| draws exactly as INRIA draws s, and TINY_SCALE keeps a zero
          scale's point-like footprint while its log (the PLY encoding) stays finite;
  "drop"  remove them;
  "error" raise SplatFormatError naming the counts.
After "fix" or "drop" every value is finite, every quaternion unit length and every scale
positive. Note: an infinite opacity logit is not "bad": the sigmoid maps it to 0 or 1.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import SplatFormatError
from .quaternion import normalize_quats_
from .splats import ARRAYS, SplatSet

POLICIES = ("fix", "drop", "error")
TINY_SCALE = float(np.finfo(np.float32).tiny)  # smallest normal float32, 1.2e-38


@dataclass
class BadValues:
    """What check_values found and did."""

    nonfinite: int = 0          # splats with any NaN/Inf value
    zero_quaternions: int = 0   # splats whose quaternion is all zeros (and otherwise finite)
    by_field: dict = field(default_factory=dict)  # field name -> splats with a non-finite value there
    action: str = "fix"
    dropped: int = 0
    nonpositive_scales: int = 0  # finite splats with a scale <= 0
    replaced: tuple | None = None  # "fix" with keep_replaced: (row indices, SplatSet of their original values)

    @property
    def total(self) -> int:
        return self.nonfinite + self.zero_quaternions + self.nonpositive_scales

    def summary(self) -> str:
        if not self.total:
            return "no NaN/Inf values, zero quaternions or non-positive scales"
        where = ", ".join(f"{k} {v}" for k, v in self.by_field.items() if v)
        verb = {"fix": "neutralised", "drop": "dropped", "error": "rejected"}[self.action]
        return (f"{self.nonfinite} splats with NaN/Inf ({where or 'none'}), "
                f"{self.zero_quaternions} zero quaternions, "
                f"{self.nonpositive_scales} negative or zero scales: {verb}")

    def as_dict(self) -> dict:
        return {"nonfinite": self.nonfinite, "zero_quaternions": self.zero_quaternions,
                "nonpositive_scales": self.nonpositive_scales,
                "by_field": dict(self.by_field), "action": self.action, "dropped": self.dropped}


def _row_sums(flat: np.ndarray) -> np.ndarray:
    """Each row's sum, without BLAS: a mat-vec with ones goes to OpenBLAS, whose idle worker
    thread then spins for about 0.1 s of CPU after each call. Narrow rows are added a
    column at a time (numpy's reduction along a row of 3 runs a loop per row)."""
    if flat.shape[1] > 8:
        return flat.sum(axis=1)
    total = flat[:, 0].copy()
    for column in range(1, flat.shape[1]):
        total += flat[:, column]
    return total


def _rows_nonfinite(arr: np.ndarray) -> np.ndarray:
    """Boolean (N,) mask of rows holding a NaN/Inf. A row sum (several times faster than
    isfinite().all()) is non-finite whenever a value is, in any order of addition; the
    rows it flags, including finite sums that overflowed, are checked exactly."""
    planes = arr.transpose(1, 0, 2) if arr.ndim == 3 else None
    if planes is not None and planes.flags.c_contiguous and not arr.flags.c_contiguous:
        # sh_rest stored as coefficient planes (formats/ply.py): sum the planes, no copy
        flat = arr
        with np.errstate(over="ignore", invalid="ignore"):
            suspect = ~np.isfinite(_row_sums(planes.sum(axis=0)))
    else:
        flat = arr.reshape(arr.shape[0], -1)
        if flat.shape[1] == 0:
            return np.zeros(arr.shape[0], bool)
        with np.errstate(over="ignore", invalid="ignore"):
            suspect = ~np.isfinite(_row_sums(flat))
    if suspect.any():
        idx = np.flatnonzero(suspect)
        suspect[idx] = ~np.isfinite(flat[idx].reshape(idx.size, -1)).all(axis=1)
    return suspect


def find_bad(splats: SplatSet) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """(nonfinite mask, zero-quaternion mask, non-positive-scale mask, per-field counts);
    a splat is counted under one heading only, NaN/Inf first."""
    n = splats.count
    nonfinite = np.zeros(n, bool)
    by_field = {}
    for name in ARRAYS:
        arr = getattr(splats, name)
        if arr.size == 0:
            by_field[name] = 0
            continue
        mask = _rows_nonfinite(arr)
        by_field[name] = int(mask.sum())
        nonfinite |= mask
    # column by column: numpy's any/min along a row of 3 or 4 runs a loop per row, 10x slower
    # (0.05 s of CPU at 1M splats); the same answers, NaN included (not zero, min is NaN)
    q, scales = splats.rotations, splats.scales
    zero_q = (q[:, 0] == 0) & (q[:, 1] == 0) & (q[:, 2] == 0) & (q[:, 3] == 0) & ~nonfinite
    nonpos = (np.minimum(np.minimum(scales[:, 0], scales[:, 1]), scales[:, 2]) <= 0) & ~nonfinite
    return nonfinite, zero_q, nonpos, by_field


def check_values(splats: SplatSet, policy: str = "fix", path=None,
                 keep_replaced: bool = False) -> tuple[SplatSet, BadValues]:
    if policy not in POLICIES:
        raise ValueError(f"bad-value policy {policy!r} is not one of {POLICIES}")
    nonfinite, zero_q, nonpos, by_field = find_bad(splats)
    report = BadValues(int(nonfinite.sum()), int(zero_q.sum()), by_field, policy,
                       nonpositive_scales=int(nonpos.sum()))
    if not report.total:
        return splats, report
    if policy == "error":
        raise SplatFormatError(path, report.summary())
    if policy == "drop":
        report.dropped = report.total
        return splats.subset(~(nonfinite | zero_q | nonpos)), report
    if keep_replaced:  # a copy of the bad rows only, before they are changed
        rows = np.flatnonzero(nonfinite | zero_q | nonpos)
        report.replaced = (rows, splats.subset(rows))
    _neutralise(splats, nonfinite, zero_q, nonpos)
    return splats, report


def _neutralise(splats: SplatSet, nonfinite: np.ndarray, zero_q: np.ndarray, nonpos: np.ndarray) -> None:
    idx = np.flatnonzero(nonfinite)
    for name in ARRAYS:
        arr = getattr(splats, name)
        rows = arr[idx]
        rows[~np.isfinite(rows)] = 0.0
        arr[idx] = rows
    splats.opacities[idx] = 0.0
    fixed = splats.rotations[idx]
    fixed[~fixed.any(axis=1)] = (1.0, 0.0, 0.0, 0.0)
    splats.rotations[idx] = normalize_quats_(fixed)  # in float64: no under/overflow to 0 or inf
    splats.rotations[zero_q] = (1.0, 0.0, 0.0, 0.0)
    rows = np.flatnonzero(nonfinite | nonpos)
    splats.scales[rows] = np.maximum(np.abs(splats.scales[rows]), np.float32(TINY_SCALE))
