"""Small scenes and metrics shared by the offscreen-renderer tests (tests/test_gl_*.py)."""
from __future__ import annotations

import numpy as np

from addon.core.axes import matrix_for
from addon.core.camera import look_at, simple_camera
from addon.core.formats import synth
from addon.core.scene import RenderItem
from addon.core.splats import SplatSet


def random_splats(n: int, degree: int = 0, seed: int = 0, spread: float = 0.5,
                  log_scale: float = -3.0) -> SplatSet:
    """A small cloud about the origin, for the offscreen renderer's tests."""
    return synth.random_splats(n, degree, seed, spread=spread, log_scale=log_scale,
                               opacity=(0.05, 1.0), rest=0.25)


def two_objects(n=1500):
    """Two overlapping clouds with different transforms: the global sort must interleave them."""
    a = random_splats(n, 3, seed=1)
    b = random_splats(n, 1, seed=2)
    wb = world_for(b, (0.15, 0.0, 0.05))
    wb[:3, :3] = wb[:3, :3] @ np.diag([1.2, 0.8, 1.0])  # non-uniform object scale
    return [RenderItem(a, world=world_for(a), key=("a", 0)),
            RenderItem(b, world=wb, key=("b", 0), opacity_scale=0.8, splat_scale=1.3)]


def world_for(splats: SplatSet, translation=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Object matrix carrying the file's axis convention (as an import would)."""
    m = np.eye(4)
    m[:3, :3] = matrix_for(splats.axes)
    m[:3, 3] = translation
    return m


def framing_camera(item: RenderItem, width: int, height: int, fov: float = 50.0,
                   direction=(0.3, -1.0, 0.35), distance: float = 1.6):
    """A camera looking at the item's middle from `distance` times its extent."""
    pos = item.splats.positions.astype(np.float64) @ item.world[:3, :3].T + item.world[:3, 3]
    lo, hi = np.percentile(pos, 2, axis=0), np.percentile(pos, 98, axis=0)
    centre, size = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo))
    d = np.asarray(direction, np.float64)
    eye = centre - d / np.linalg.norm(d) * size * distance
    return simple_camera(width, height, fov, look_at(eye, centre), near=0.01 * size, far=100.0 * size)


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return float("inf") if mse == 0 else 10.0 * np.log10(1.0 / mse)
