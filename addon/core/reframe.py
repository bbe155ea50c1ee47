"""Re-express a SplatSet in another file axis convention (for writing a format whose
convention differs from the data's, e.g. an SPZ import exported as .ply).

Importing never does this: the convention goes on the object's transform. Export
does it only when the target format's convention differs from the data's.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .axes import matrix_for
from .sh import sh_basis
from .splats import SplatSet, sh_coeff_count


def _quat_from_matrix(r: np.ndarray) -> np.ndarray:
    """w, x, y, z of a proper rotation matrix (the axis conversions are all 90/180 degrees,
    so the simple trace branch is not enough: use the largest-diagonal branch)."""
    m = r
    t = np.trace(m)
    if t > 0:
        s = 2.0 * np.sqrt(1.0 + t)
        return np.array([s / 4, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s])
    i = int(np.argmax(np.diag(m)))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
    q = np.empty(4)
    q[0] = (m[k, j] - m[j, k]) / s
    q[1 + i] = s / 4
    q[1 + j] = (m[j, i] + m[i, j]) / s
    q[1 + k] = (m[k, i] + m[i, k]) / s
    return q


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of (4,) a with (N, 4) b, wxyz."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b[:, 0], b[:, 1], b[:, 2], b[:, 3]
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=1)


def sh_rotation(r: np.ndarray, degree: int) -> np.ndarray:
    """(K, K) matrix M with rest' = M @ rest (per channel) for directions rotated by r.

    Solved by least squares on sampled directions: exact to rounding, because each SH band
    is closed under rotation, and it cannot disagree with sh_basis's sign conventions.
    """
    k = sh_coeff_count(degree)
    if k == 0:
        return np.zeros((0, 0))
    dirs = np.random.default_rng(0).normal(size=(64, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    target = sh_basis(dirs, degree)[:, 1:]
    source = sh_basis(dirs @ r, degree)[:, 1:]  # rows r^T d: the source direction of d
    return np.linalg.lstsq(target, source, rcond=None)[0]


def reframe(splats: SplatSet, axes: str) -> SplatSet:
    """The same Gaussians with coordinates in convention `axes` (a new set; input untouched)."""
    if splats.axes == axes:
        return splats
    r = matrix_for(axes).T @ matrix_for(splats.axes)  # source file frame -> target file frame
    q = _quat_from_matrix(r)
    rotations = _quat_mul(q, splats.rotations.astype(np.float64))
    m = sh_rotation(r, splats.sh_degree)
    rest = np.einsum("jk,nkc->njc", m, splats.sh_rest.astype(np.float64)) if m.size else splats.sh_rest
    return replace(
        splats,
        positions=(splats.positions.astype(np.float64) @ r.T).astype(np.float32),
        rotations=rotations.astype(np.float32),
        sh_rest=np.asarray(rest, np.float32).reshape(splats.sh_rest.shape),
        axes=axes,
    )
