"""Which side of a capture was photographed: the level direction its splats face.

No format Splatline reads records where the capture's cameras stood, and the file's forward
axis is the frame of whatever camera the trainer chose as its reference (often one at the
subject's side or back). What a capture does keep is its surfaces: a trained splat on a
surface is flat, its thin axis along the surface's normal. Oriented away from the subject's
middle, those normals add up to nothing over a surface seen from every side (a closed
surface's normals integrate to zero), and point towards the cameras over one seen from one
side only (a hemisphere's mean outward normal is half its axis). So the mean oriented
normal, weighted by opacity and flatness, says where the cameras stood, and its length how
sure that is (0 for a capture from all round, 0.5 for a bare hemisphere).
"""
from __future__ import annotations

import numpy as np

SAMPLE = 1 << 16  # a strided sample is plenty for one mean direction


def sample_stride(count: int) -> int:
    """The stride of a sample of at most SAMPLE of `count` splats."""
    return max(1, -(-count // SAMPLE))


def splat_normals(rotations, scales, linear=None) -> tuple[np.ndarray, np.ndarray]:
    """Each splat's thin axis (unit) and its flatness, 1 - the smallest scale over the
    middle one (0 for a ball, which has no normal). rotations: (N, 4) unit quaternions
    w, x, y, z; scales: (N, 3) linear; linear: the 3x3 that takes the splats' space to the
    world (default: the same space)."""
    q = np.asarray(rotations, np.float64).reshape(-1, 4)
    s = np.abs(np.asarray(scales, np.float64).reshape(-1, 3))
    w, x, y, z = q.T
    columns = np.stack([  # the rotation matrix's columns: where each local axis goes
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)], axis=1),
        np.stack([2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)], axis=1),
        np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], axis=1)])
    normals = columns[np.argmin(s, axis=1), np.arange(len(s))]
    if linear is not None:  # normals of a scaled object: the inverse transpose
        normals = normals @ np.linalg.inv(np.asarray(linear, np.float64)[:3, :3])
        normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    ordered = np.sort(s, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        flatness = np.where(ordered[:, 1] > 0.0, 1.0 - ordered[:, 0] / ordered[:, 1], 0.0)
    return normals, np.nan_to_num(flatness, nan=0.0)


def facing(points, normals, weights, centre, up) -> np.ndarray:
    """The level direction (3,) the splats face, seen from `centre`, as long as the facing
    is sure (0-1): the weighted mean of their world `normals`, each turned away from
    `centre`, less its part along `up`. weights: opacity times flatness, say."""
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    normals = np.asarray(normals, np.float64).reshape(-1, 3)
    weight = np.clip(np.nan_to_num(np.asarray(weights, np.float64)), 0.0, None)
    weight = weight * np.sign(np.einsum("ij,ij->i", normals, pts - np.asarray(centre, np.float64)))
    good = np.isfinite(weight) & np.isfinite(normals).all(axis=1)
    total = float(np.abs(weight[good]).sum())
    if total <= 0.0:
        return np.zeros(3)
    mean = weight[good] @ normals[good] / total
    up = np.asarray(up, np.float64)
    return mean - up * float(mean @ up)
