"""Splat normals for lighting: each splat's shortest axis, in world space, turned to face the
viewer. A trained surface is mostly flat splats lying in it, so the axis a splat is thinnest
along is the surface's normal there (bench/lighting_normals_bench.py measures how well, on
generated captures with a known surface); a round splat has no such axis, and its normal is
only as good as its noise.

The sign: a splat is a thin two-sided sheet. The side that shows is the one the viewer looks
at, so the normal is turned towards `eye` (the scene camera's position, the same in every
path: a frame stays a function of the scene). A light behind the sheet, seen from the
viewer's side, then lights nothing, as a mesh plane's back would show."""
from __future__ import annotations

import numpy as np


def shortest_axes(rotations: np.ndarray, scales: np.ndarray) -> np.ndarray:
    """(N, 3) float64 unit object-space axes along each splat's smallest scale (wxyz quaternions;
    a zero quaternion counts as the identity)."""
    q = np.asarray(rotations, np.float64)
    norm = np.linalg.norm(q, axis=1)
    q = np.where((norm > 0)[:, None], q / np.where(norm > 0, norm, 1.0)[:, None], [1.0, 0, 0, 0])
    j = np.argmin(np.asarray(scales), axis=1)
    # Column j of the rotation matrix alone. The columns are one formula under the cyclic
    # relabelling x -> y -> z: with (a, b, c) the quaternion's (x, y, z) rolled to start at j,
    # column j holds (1 - 2(b^2 + c^2), 2(ab + wc), 2(ac - wb)) at rows j, j+1, j+2.
    roll = (j[:, None] + np.arange(3)[None, :]) % 3
    w = q[:, 0]
    a, b, c = np.take_along_axis(q[:, 1:], roll, axis=1).T
    out = np.empty((len(q), 3))
    np.put_along_axis(out, roll, np.stack([1 - 2 * (b * b + c * c), 2 * (a * b + w * c),
                                           2 * (a * c - w * b)], 1), axis=1)
    return out


def world_normals(axes: np.ndarray, world: np.ndarray) -> np.ndarray:
    """Object-space normals to unit world-space ones: by the inverse transpose of the world
    matrix's 3x3 (a non-uniform scale tilts normals the other way from the surface), as its
    cofactor matrix times the determinant's sign, which is that up to a positive factor and
    defined for a flattened object too (scaled to 0 along an axis, as a keyed grow starts):
    its normals are then its plane's, and an object shrunk to a line or a point has none
    (zero normals: lit by the World alone). The viewport's shader computes the same."""
    m = np.asarray(world, np.float64)[:3, :3]
    c0, c1, c2 = m[:, 0], m[:, 1], m[:, 2]
    cofactor = np.stack([np.cross(c1, c2), np.cross(c2, c0), np.cross(c0, c1)], axis=1)
    normal_matrix = cofactor if np.dot(c0, np.cross(c1, c2)) >= 0 else -cofactor
    n = axes @ normal_matrix.T
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return n / np.where(length > 0, length, 1.0)


def facing(normals: np.ndarray, points: np.ndarray, eye) -> np.ndarray:
    """The normals, each turned to the side of its splat that `eye` sees."""
    towards = np.asarray(eye, np.float64)[None, :] - points
    flip = np.einsum("ij,ij->i", normals, towards) < 0
    return np.where(flip[:, None], -normals, normals)


def world_points(splats, world: np.ndarray) -> np.ndarray:
    """(N, 3) float64 world-space centres."""
    world = np.asarray(world, np.float64)
    return splats.positions.astype(np.float64) @ world[:3, :3].T + world[:3, 3]


def splat_normals(splats, world: np.ndarray, eye, points=None) -> tuple[np.ndarray, np.ndarray]:
    """(world-space centres, unit world normals facing eye), float64; `points`, the centres
    when the caller has them already. eye None (no camera): the normals as the rotations
    give them, and the shading takes both sides as lit."""
    world = np.asarray(world, np.float64)
    points = world_points(splats, world) if points is None else points
    normals = world_normals(shortest_axes(splats.rotations, splats.scales), world)
    return points, (normals if eye is None else facing(normals, points, eye))
