"""Small scenes and metrics shared by the offscreen-renderer tests (tests/test_gl_*.py)."""
from __future__ import annotations

import numpy as np

from dataclasses import replace

from addon.core import reference
from addon.core.axes import matrix_for
from addon.core.camera import look_at, simple_camera
from addon.core.formats import read
from testing import synth
from addon.core.preprocess import project
from addon.core.scene import RenderItem, RenderOptions
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


def assert_depth_matches(out, items, cam, options: RenderOptions, window=None):
    """The Z pass against the reference's (alpha-weighted depth, inf below alpha 0.5).

    Against the reference WITHOUT early termination: the GL renderer stops a pixel at the
    end of the batch in which T fell below 1e-4, so its weights differ from the full
    composite's by < 1e-4 in all, while the reference's exact (INRIA) stop leaves out the
    splat that would cross, up to T <= 1e-4 / (1 - 0.99) = 1% of the weight. Float32
    sums of a few hundred weighted depths round to ~1e-6 relative; 2e-5 is the bar, with
    the 1e-4 weight allowance on top: at alpha >= 0.5 it moves the weighted mean by at most
    2e-4 of the splats' depth range.
    Pixels whose alpha lies within rounding of 0.5 may flip between a depth and inf, and a
    pixel centre within rounding of a quad's edge (capped extent: alpha <= 0.011 there) or
    of the 1/255 cut adds or drops one splat of that weight: such events (a few per mille
    of the pixels) move a depth by at most 0.011 / 0.5 of that range.
    window: out is that (x, y, w, h) crop of cam's frame (the reference renders only it)."""
    ref = reference.render(items, cam, replace(options, early_termination=False), window=window)
    fin = np.isfinite(ref.depth)
    assert fin.mean() > 0.05  # the test sees depths at all
    assert np.mean(np.isfinite(out.depth) != fin) < 1e-3
    both = fin & np.isfinite(out.depth)
    depths = np.concatenate([p.depth[p.valid] for p in (project(i, cam) for i in items)])
    span = float(depths.max() - depths.min())
    err = np.abs(out.depth[both].astype(np.float64) - ref.depth[both])
    tight = err <= 2e-5 * np.abs(ref.depth[both]) + 2e-4 * span
    assert tight.mean() > 0.995 and (err <= 0.022 * span).all()


def guitar_with_axes(testdata):
    """guitar.ply (90,854 splats) with its real (RDF) axes, and a camera framing it."""
    splats = read(testdata / "guitar.ply")
    world = np.eye(4)
    world[:3, :3] = matrix_for(splats.axes)
    item = RenderItem(splats, world=world, key=("guitar", 0))
    return item, framing_camera(item, 320, 240, distance=1.1)
