"""The inverse of a 4x4 transform without LAPACK.

numpy's inv goes through OpenBLAS, whose LU factorisation wakes its thread pool even for a
4x4 matrix; those threads then spin on a core for a while. Called a few times a frame
(effect gizmos, cameras, objects), that took a core from the drawing thread and the effect
kernels for most of every frame on a two-core machine. Here: cofactors built from the 2x2
minors of the top and bottom row pairs (Laplace expansion), in Python floats.
"""
from __future__ import annotations

import math

import numpy as np


def inverse4(m) -> np.ndarray:
    """The inverse of the 4x4 matrix m (float64); np.linalg.LinAlgError when it is singular,
    as np.linalg.inv raises. A matrix holding NaN or infinity (a broken transform: rare) is
    numpy's to invert, so what comes back is what it always was."""
    a = np.asarray(m, np.float64)
    if a.shape != (4, 4):
        raise ValueError(f"inverse4 takes a 4x4 matrix, not {a.shape}")
    if not np.isfinite(a).all():
        return np.linalg.inv(a)
    (a00, a01, a02, a03), (a10, a11, a12, a13), (a20, a21, a22, a23), (a30, a31, a32, a33) = a.tolist()
    # minors of rows 0-1 (s) and rows 2-3 (c), by column pair
    s0, s1, s2 = a00 * a11 - a10 * a01, a00 * a12 - a10 * a02, a00 * a13 - a10 * a03
    s3, s4, s5 = a01 * a12 - a11 * a02, a01 * a13 - a11 * a03, a02 * a13 - a12 * a03
    c0, c1, c2 = a20 * a31 - a30 * a21, a20 * a32 - a30 * a22, a20 * a33 - a30 * a23
    c3, c4, c5 = a21 * a32 - a31 * a22, a21 * a33 - a31 * a23, a22 * a33 - a32 * a23
    det = s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0
    if det == 0.0:
        raise np.linalg.LinAlgError("Singular matrix")
    r = 1.0 / det
    return np.array([
        [(a11 * c5 - a12 * c4 + a13 * c3) * r, (-a01 * c5 + a02 * c4 - a03 * c3) * r,
         (a31 * s5 - a32 * s4 + a33 * s3) * r, (-a21 * s5 + a22 * s4 - a23 * s3) * r],
        [(-a10 * c5 + a12 * c2 - a13 * c1) * r, (a00 * c5 - a02 * c2 + a03 * c1) * r,
         (-a30 * s5 + a32 * s2 - a33 * s1) * r, (a20 * s5 - a22 * s2 + a23 * s1) * r],
        [(a10 * c4 - a11 * c2 + a13 * c0) * r, (-a00 * c4 + a01 * c2 - a03 * c0) * r,
         (a30 * s4 - a31 * s2 + a33 * s0) * r, (-a20 * s4 + a21 * s2 - a23 * s0) * r],
        [(-a10 * c3 + a11 * c1 - a12 * c0) * r, (a00 * c3 - a01 * c1 + a02 * c0) * r,
         (-a30 * s3 + a31 * s1 - a32 * s0) * r, (a20 * s3 - a21 * s1 + a22 * s0) * r],
    ])


def inverse_or_pinv(m) -> np.ndarray:
    """The inverse of a 4x4 (or 3x3) transform by inverse4; the pseudo-inverse where it is
    singular (an object or gizmo scaled to 0 on some axis), so a degenerate transform
    never stops evaluation or drawing (what comes back then is junk the renderers cull)."""
    a = np.asarray(m, np.float64)
    if a.shape == (3, 3):
        padded = np.eye(4)
        padded[:3, :3] = a
        return inverse_or_pinv(padded)[:3, :3]
    try:
        return inverse4(a)
    except np.linalg.LinAlgError:
        return np.linalg.pinv(a)


FLAT = 1e-6  # the least scale a transform keeps along any axis, relative to its largest


def thickened(m) -> np.ndarray:
    """The 4x4 transform m with no axis scaled below FLAT times its largest scale. An object
    scaled to 0 along an axis (a keyed grow's first frame) is a plane: the renderers work in
    its local frame, through the inverse, so it keeps a millionth of a thickness there and
    draws as that plane (a millionth of its size from where it is). m itself where it is
    thick enough, holds no scale at all (a point: nothing to draw) or is not finite. The
    SVD goes to LAPACK, but only for such a transform."""
    a = np.asarray(m, np.float64)
    linear = a[:3, :3]
    values = linear.tolist()  # Python floats: this runs for every object and instance drawn
    (p, q, r), (d, e, f), (g, h, i) = values
    big = max(abs(v) for row in values for v in row)
    # |det| = s0 s1 s2 <= s0^2 s2 and s0 <= 3 big: at 27 FLAT big^3, s2 >= FLAT s0 already
    det = p * (e * i - f * h) - q * (d * i - f * g) + r * (d * h - e * g)
    if not math.isfinite(det) or big == 0.0 or abs(det) >= 27.0 * FLAT * big ** 3:
        return a
    u, s, vt = np.linalg.svd(linear)
    if s[2] >= FLAT * s[0]:
        return a
    out = a.copy()
    out[:3, :3] = (u * np.maximum(s, FLAT * s[0])) @ vt
    return out
