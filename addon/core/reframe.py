"""Re-express a SplatSet in another frame: another file axis convention (`reframe`, for
writing a format whose convention differs from the data's, e.g. an SPZ import exported as
.ply), or another object's space (`map_into`, a morph target seen from the source object).

Importing never reframes: the convention goes on the object's transform. Export does it
only when the target format's convention differs from the data's. Rotations turn the
centres, the quaternions and the higher SH bands alike (`turn`, `rotate_sh`), so the
view-dependent colour turns with the splats.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from . import quaternion
from .axes import matrix_for
from .sh import sh_basis
from .splats import SplatSet, sh_coeff_count, sh_degree_for


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


def rotate_sh(rest: np.ndarray, rot: np.ndarray, dtype=np.float64) -> np.ndarray:
    """Higher SH (N, K, 3) of splats turned by rot (computed in dtype, float32 out); the
    same array where rot leaves them unchanged (degree 0, or no turn)."""
    m = sh_rotation(rot, sh_degree_for(rest.shape[1]))
    if m.size == 0 or np.allclose(m, np.eye(len(m)), atol=1e-9):
        return rest
    # one (K, K) @ (K, 3) product per splat, broadcast: the einsum it replaces took 1.87 s
    # at 1M degree-3 splats, this 0.84 s (an LCC convert to .ply spent the 1.9 s turning SH)
    out = np.matmul(m.astype(dtype), rest.astype(dtype, copy=False))
    return out.astype(np.float32, copy=False).reshape(rest.shape)


def turn(splats: SplatSet, r: np.ndarray, dtype=np.float64) -> tuple:
    """(rotations, sh_rest) of splats turned by the rotation matrix r (their centres are the
    caller's: r p, then its own scale and move). Computed in `dtype`: float32 for a morph
    target, re-mapped whenever it moves (3x faster at 1M splats than float64)."""
    q = quaternion.from_matrix(np.asarray(r, np.float64)[None]).astype(dtype)
    rotations = quaternion.multiply(q, splats.rotations.astype(dtype, copy=False))
    return rotations, rotate_sh(splats.sh_rest, r, dtype)


def reframe(splats: SplatSet, axes: str) -> SplatSet:
    """The same Gaussians with coordinates in convention `axes` (a new set; input untouched)."""
    if splats.axes == axes:
        return splats
    r = matrix_for(axes).T @ matrix_for(splats.axes)  # source file frame -> target file frame
    rotations, rest = turn(splats, r)
    positions = (splats.positions.astype(np.float64) @ r.T).astype(np.float32)
    return replace(splats, positions=positions, rotations=rotations, sh_rest=rest, axes=axes)


def map_into(splats: SplatSet, relative: np.ndarray) -> SplatSet:
    """Splats of another object expressed in this object's space (relative: 4x4 this<-that).

    The linear part is split as R * s with s the cube root of |det| (exact for rotation and
    uniform scale; a non-uniform relative scale is approximated by its mean). R turns the
    centres, the rotations and the SH coefficients."""
    linear = relative[:3, :3]
    s = abs(np.linalg.det(linear)) ** (1.0 / 3.0)
    if s == 0.0:
        return splats
    u, _, vt = np.linalg.svd(linear / s)
    rotations, rest = turn(splats, u @ vt, np.float32)
    positions = (splats.positions.astype(np.float64) @ linear.T + relative[:3, 3]).astype(np.float32)
    return SplatSet(positions, splats.scales * np.float32(s), rotations, splats.opacities,
                    splats.sh_dc, rest, splats.axes)
