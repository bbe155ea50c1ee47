"""The two-object scene and the offscreen drawing helper of the viewport tests."""
from __future__ import annotations

import numpy as np

from addon.core.camera import look_at, simple_camera
from addon.core.formats import read
from .synth import random_splats
from addon.core.scene import RenderItem
from addon.core.splats import SplatSet


def rotation(axis, degrees) -> np.ndarray:
    a = np.asarray(axis, np.float64) / np.linalg.norm(axis)
    t = np.radians(degrees)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(t) * k + (1 - np.cos(t)) * k @ k


def blob(n: int, degree: int, seed: int, centre, spread: float) -> SplatSet:
    return random_splats(n, degree, seed, centre=centre, spread=spread,
                         log_scale=np.log(0.4 * spread), opacity=(0.1, 0.95), rest=0.25)


def two_objects(testdata):
    """test64.ply (degree 3, its own RDF frame) and a rotated, scaled degree-1 blob
    placed inside it, so the two interleave in depth."""
    capture = read(testdata / "test64.ply")
    world_a = np.eye(4)
    world_a[:3, :3] = rotation((1, 0, 0), -90)  # RDF (y down, z forward) -> Blender z up
    world_a[:3, 3] = (1.2, -0.4, 0.8)
    centre = world_a[:3, :3] @ capture.positions.mean(0) + world_a[:3, 3]
    other = blob(120, 1, seed=7, centre=(0, 0, 0), spread=0.08)
    world_b = np.eye(4)
    world_b[:3, :3] = rotation((0.3, 1.0, 0.5), 50) * np.array([1.0, 1.5, 0.7])  # non-uniform
    world_b[:3, 3] = centre
    return [RenderItem(capture, world_a), RenderItem(other, world_b)], centre


def camera_for(centre, width=120, height=90):
    eye = np.asarray(centre) + np.array([0.35, -0.9, 0.3])
    return simple_camera(width, height, 45.0, look_at(eye, centre), near=0.05, far=50.0)


def draw_offscreen(items, camera, displays=None, settings=None, renderer=None):
    """Draw through the viewport path into an RGBA32F GPUOffScreen; top-down float32."""
    from addon.blender.viewport import ViewportRenderer
    from addon.blender.viewport.offscreen import draw_camera

    renderer = renderer or ViewportRenderer()
    rgba = draw_camera(items, camera, settings=settings, displays=displays, renderer=renderer)
    return rgba, renderer


def _texels(texture, channels: int) -> np.ndarray:
    return np.array(texture.read().to_list(), np.float32).reshape(-1, channels)


def records(items, camera, renderer=None) -> tuple[np.ndarray, dict]:
    """(drawn splat indices, {record name: (drawn, 4)}) of one viewport draw (in `renderer`,
    left open, where given)."""
    _, drew = draw_offscreen(items, camera, renderer=renderer)
    gpu_ = drew.gpu
    n = gpu_.order_count
    order = _texels(gpu_.textures["order"], 1)[:n, 0].astype(np.int64)
    recs = {name: _texels(t, 4)[:n] for name, t in gpu_.records.items()}
    if renderer is None:
        drew.close()
    return order, recs


def by_splat(order, rec, n):
    """{splat: its 12 record values} of two copies of n splats drawn together: the first
    copy's and the second's (indices n.. as 0..)."""
    flat = np.concatenate([rec["rec_pos"], rec["rec_conic"], rec["rec_color"]], axis=1)
    first = {int(i): flat[k] for k, i in enumerate(order) if i < n}
    second = {int(i) - n: flat[k] for k, i in enumerate(order) if i >= n}
    return first, second


def psnr(a, b) -> float:
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return float("inf") if mse == 0 else 10.0 * np.log10(1.0 / mse)


def overlay_drawn(obj):
    """A splat object Splatline's viewport overlay draws: on Blender 5.3+ every Splatline
    import is a native splat PointCloud that Blender draws itself (and the overlay skips),
    so the overlay's tests use one switched back to plain points, as a user may do."""
    from addon.blender.data import native

    if native.has_native_splats():
        obj.data.type = "POINTS"
    return obj
