"""A linear map (and a move) baked into splats: the splats that, drawn with an identity
transform, are what the original ones drawn through p -> L p + t are. Shared by the command
line's `convert --rotate/--scale` (edit.transform) and Blender's Apply > Splat Rotation &
Scale (blender/ops/apply_transform.py).

What is exact:
- centres: L p + t;
- shapes: a Gaussian's covariance becomes L Σ Lᵀ, which is again R' S'² R'ᵀ for some
  rotation R' and scales S' (its eigen-decomposition): exact for any invertible L, also a
  non-uniform one (the ellipsoid's axes are then no longer the splat's own);
- view-dependent colour: the renderers look the SH up along the view direction in the
  object's frame, normalize(L⁻¹ d). Where L = s Q (Q orthogonal, s > 0) that is Qᵀ d, and
  each band turns (and under a mirror flips by (-1)^l) into a band of the same degree:
  exact. Under a non-uniform L the direction map bends the sphere, and no SH of the same
  degree reproduces it: such a map is refused for splats with higher bands (degree 0
  colour does not depend on the direction, so it is baked).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from . import quaternion
from .reframe import turn
from .splats import SplatSet

UNIFORM_TOLERANCE = 1e-6  # relative spread of L's singular values still taken as uniform


class NotExact(ValueError):
    """The map cannot be baked into the splats exactly (a non-uniform scale of SH colour)."""


def similarity(linear: np.ndarray) -> tuple[float, np.ndarray] | None:
    """(s, Q) with linear = s Q, Q orthogonal (a rotation, or a rotation and a mirror), or
    None where linear scales unevenly."""
    singular = np.linalg.svd(linear, compute_uv=False)
    if singular[-1] <= 0 or not np.all(np.isfinite(singular)):
        raise ValueError("the transform is not invertible (a zero scale)")
    s = float(np.cbrt(abs(np.linalg.det(linear))))
    if singular[0] - singular[-1] > UNIFORM_TOLERANCE * s:
        return None
    return s, linear / s


def parity(rest: np.ndarray) -> np.ndarray:
    """Higher SH (N, K, 3) of the directions turned inside out (d -> -d): band l by (-1)^l."""
    sign = np.array([(-1.0) ** l for l in (1, 2, 3) for _ in range(2 * l + 1)][:rest.shape[1]], np.float32)
    return rest * sign[None, :, None]


def has_view_colour(splats: SplatSet) -> bool:
    return splats.sh_rest.size > 0 and bool(np.any(splats.sh_rest))


def bake(splats: SplatSet, linear, translate=(0.0, 0.0, 0.0)) -> SplatSet:
    """The splats moved through p -> linear p + translate (a new set; input untouched).
    Raises NotExact for a non-uniform linear on splats with view-dependent colour."""
    linear = np.asarray(linear, np.float64)
    found = similarity(linear)
    positions = (splats.positions.astype(np.float64) @ linear.T + np.asarray(translate, np.float64))
    if found is not None:
        s, q = found
        mirrored = np.linalg.det(q) < 0
        r = -q if mirrored else q  # Q Σ Qᵀ = R Σ Rᵀ: the ellipsoid turns by the proper part
        source = replace(splats, sh_rest=parity(splats.sh_rest)) if mirrored else splats
        rotations, rest = turn(source, r)
        return replace(splats, positions=positions.astype(np.float32), rotations=rotations,
                       scales=(splats.scales * np.float32(s)).astype(np.float32), sh_rest=rest)
    if has_view_colour(splats):
        raise NotExact("a non-uniform scale bends the view directions of the splats' SH colour, "
                       "which no SH of the same degree can follow: apply a uniform scale, or "
                       "drop the higher SH bands first")
    rotations, scales = _covariances(splats, linear)
    return replace(splats, positions=positions.astype(np.float32), rotations=rotations, scales=scales)


def _covariances(splats: SplatSet, linear: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rotations, scales) of the covariances linear Σ linearᵀ, by eigen-decomposition."""
    r, _ = quaternion.to_matrix(splats.rotations)
    axes = r * splats.scales.astype(np.float64)[:, None, :]  # columns: the scaled axes
    mapped = linear[None] @ axes
    values, vectors = np.linalg.eigh(mapped @ mapped.transpose(0, 2, 1))
    flip = np.linalg.det(vectors) < 0
    vectors[flip, :, 0] *= -1.0  # a proper rotation: an eigenvector's sign is free
    scales = np.sqrt(np.maximum(values, 0.0)).astype(np.float32)
    return quaternion.from_matrix(vectors).astype(np.float32), scales

