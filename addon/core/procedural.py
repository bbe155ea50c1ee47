"""Procedural, capture-like splat objects for the demo and benchmarks (no external data).

Splats sit on a surface as flat discs oriented along it, like a trained capture's,
with a view-dependent SH sheen so the higher bands visibly matter.
"""
from __future__ import annotations

import numpy as np

from . import quaternion
from .sh import C0
from .splats import AXES_RFU, SplatSet


# Splats per surface area: each splat's 1-sigma disc area times the count, over the surface
# area, is this many layers. Trained captures sit around here; a fixed splat size instead
# makes a dense set hundreds of layers deep, which costs fill rate for no visible change.
COVERAGE = 6.0
_KNOT_AREA = 17.7  # (2, 3) knot: curve length 10.06 x tube circumference 2*pi*0.28
_DISC_ASPECT = 1.4  # splats are 1.4 x 1.0 x 0.08 of their size


def disc_size(n: int, area: float, coverage: float = COVERAGE) -> float:
    """Splat size for n splats covering `area` about `coverage` layers deep."""
    return float(np.sqrt(coverage * area / (max(n, 1) * np.pi * _DISC_ASPECT)))


def torus_knot(n: int, degree: int = 3, p: int = 2, q: int = 3, seed: int = 0,
               size: float | None = None) -> SplatSet:
    """A (p, q) torus knot tube about 2 units across, coloured by a hue ramp along the curve.
    size: splat size; default disc_size for the (2, 3) knot's area, so any n looks alike."""
    rng = np.random.default_rng(seed)
    t = rng.uniform(0.0, 2.0 * np.pi, n)
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    centre, tangent = _knot_curve(t, p, q), _knot_curve(t + 1e-4, p, q) - _knot_curve(t - 1e-4, p, q)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    side = np.cross(tangent, centre)
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    normal_axis = np.cross(side, tangent)
    normal = np.cos(phi)[:, None] * normal_axis + np.sin(phi)[:, None] * side
    tube = 0.28 * (1.0 + 0.08 * np.sin(7 * t))[:, None]
    positions = centre + tube * normal
    hue = (t / (2.0 * np.pi) * 2.0) % 1.0
    rgb = _hue_to_rgb(hue) * (0.55 + 0.45 * (0.5 + 0.5 * np.cos(phi)))[:, None]
    size = disc_size(n, _KNOT_AREA) if size is None else size
    return _surface_splats(positions, normal, tangent, rgb, degree, rng, size=size)


def planet(n: int, degree: int = 3, seed: int = 1, size: float | None = None) -> SplatSet:
    """A unit-radius sphere with noise continents, oceans and polar caps.
    size: splat size; default disc_size for the sphere's area."""
    rng = np.random.default_rng(seed)
    normal = rng.normal(size=(n, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    land = _lumpy(normal, rng) > 0.15
    positions = normal * (1.0 + np.where(land, 0.03, 0.0))[:, None]
    rgb = np.where(land[:, None], [0.25, 0.55, 0.2], [0.08, 0.25, 0.65])
    polar = np.abs(normal[:, 2]) > 0.85
    rgb[polar] = [0.92, 0.94, 0.97]
    tangent = np.cross(normal, [0.0, 0.0, 1.0])
    bad = np.linalg.norm(tangent, axis=1) < 1e-6
    tangent[bad] = [1.0, 0.0, 0.0]
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    size = disc_size(n, 4.0 * np.pi) if size is None else size
    return _surface_splats(positions, normal, tangent, rgb, degree, rng, size=size)


def _knot_curve(t: np.ndarray, p: int, q: int) -> np.ndarray:
    r = 0.65 + 0.3 * np.cos(q * t)
    return np.stack([r * np.cos(p * t), r * np.sin(p * t), 0.3 * np.sin(q * t)], axis=1)


def _lumpy(normal: np.ndarray, rng) -> np.ndarray:
    """A cheap smooth field on the sphere: a sum of random low-frequency waves."""
    field = np.zeros(normal.shape[0])
    for freq in (2.0, 4.0, 8.0):
        direction = rng.normal(size=(4, 3))
        phase = rng.uniform(0, 2 * np.pi, 4)
        field += (np.sin(freq * normal @ direction.T + phase) / freq).sum(axis=1)
    return field


def _hue_to_rgb(h: np.ndarray) -> np.ndarray:
    k = (np.array([5.0, 3.0, 1.0]) + h[:, None] * 6.0) % 6.0
    return 1.0 - np.clip(np.minimum(k, 4.0 - k), 0.0, 1.0) * 0.85


def _surface_splats(positions, normal, tangent, rgb, degree, rng, size) -> SplatSet:
    n = positions.shape[0]
    bitangent = np.cross(normal, tangent)
    basis = np.stack([tangent, bitangent, normal], axis=2)  # columns: local x, y, z
    splats = SplatSet.allocate(n, degree, AXES_RFU)
    splats.positions[:] = positions
    splats.rotations[:] = quaternion.from_matrix(basis)
    jitter = rng.uniform(0.7, 1.3, (n, 1))
    splats.scales[:] = size * jitter * np.array([1.4, 1.0, 0.08])
    splats.opacities[:] = rng.uniform(0.75, 1.0, n)
    splats.sh_dc[:] = (rgb - 0.5) / C0
    if degree >= 1:
        # A cool sheen toward +x and warm toward -x: visible as the camera orbits.
        splats.sh_rest[:, 2] = np.array([-0.12, 0.0, 0.12])
    if degree >= 2:
        splats.sh_rest[:, 5] = 0.06
    return splats


def coherent_order(positions: np.ndarray, slices: int = 256) -> np.ndarray:
    """Splat order by azimuth about the z axis in equal-count slices, then by height in each.

    Two sets of the same count in this order, paired by index (as the morph pairs equal
    counts), morph as a sweep in which each splat keeps its bearing and its rank in height,
    instead of a swarm: equal-count slices line the two sets' slices up exactly."""
    azimuth = np.arctan2(positions[:, 1], positions[:, 0])
    rank = np.empty(len(azimuth), np.int64)
    rank[np.argsort(azimuth, kind="stable")] = np.arange(len(azimuth))
    slice_index = rank * slices // max(1, len(azimuth))
    return np.lexsort((positions[:, 2], slice_index))
