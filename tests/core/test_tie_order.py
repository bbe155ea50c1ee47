"""Exact depth ties: the lower index is in front, as INRIA's and gsplat's stable key
sorts give (they sort front to back, stably). Across objects, the index is the global
one: objects in the order given, then their splats. Pinned in the reference, every
fast path (moderngl with the GPU radix sort, its CPU sort and its GL 3.3 fallback, the
viewport's gpu draw) and every CPU sort (core/sort.py's 16- and 32-bit radix sorts and
the viewport's culling sort).

Two splats of one shape at one centre have the same alpha a at every pixel, so the one
in front gives a c_front + (1 - a) a c_back: its colour channel is the larger wherever
a pixel is lit, and it wins by a factor 1 / (1 - a) >= 1.0039 (a >= 1/255).
"""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.scene import RenderItem, RenderOptions
from addon.core.sort import back_to_front, depth_keys, far_to_near
from testing.footprint_scenes import PATHS, camera, gl, gl33, gpu_ready, render_rgba, splats  # noqa: F401

RED, GREEN = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)
OPTIONS = [RenderOptions(), RenderOptions(key_bits=16), RenderOptions(gpu_sort=False)]


def _red_in_front(rgba: np.ndarray) -> None:
    lit = rgba[..., 3] > 0
    assert lit.sum() > 100
    front, back = rgba[..., 0][lit], rgba[..., 1][lit]
    assert (front > back).all(), f"green (the higher index) in front at {(front <= back).sum()} pixels"


@pytest.mark.parametrize("options", OPTIONS, ids=["32bit", "16bit", "cpu-sort"])
@pytest.mark.parametrize("path", PATHS)
def test_equal_depths_composite_in_index_order(path, options, request):
    items = [RenderItem(splats([RED, GREEN], opacity=0.6))]
    _red_in_front(render_rgba(path, request, items, camera(), options))


@pytest.mark.parametrize("path", PATHS)
def test_across_objects_the_first_object_is_in_front(path, request):
    """Global index: object order, then splat order."""
    items = [RenderItem(splats([RED], opacity=0.6)), RenderItem(splats([GREEN], opacity=0.6))]
    _red_in_front(render_rgba(path, request, items, camera()))


def _expected(depth: np.ndarray, bits: int) -> np.ndarray:
    """Back to front by key (key 0 farthest); equal keys: higher index first."""
    keys = depth_keys(depth, bits)
    idx = np.arange(depth.size)
    return np.lexsort((-idx, keys))


def _depths_with_ties(n: int = 6000, seed: int = 3) -> np.ndarray:
    """Few distinct depths, many equal: ties within and across 2048-element radix blocks."""
    rng = np.random.default_rng(seed)
    return rng.choice(np.array([1.5, 2.0, 2.0 + 1e-7, 7.25], np.float32), n)


@pytest.mark.parametrize("bits", [16, 32])
def test_cpu_sorts_put_the_lower_index_in_front(bits):
    depth = _depths_with_ties()
    np.testing.assert_array_equal(back_to_front(depth, bits), _expected(depth, bits))
    np.testing.assert_array_equal(far_to_near(depth, bits), _expected(depth, bits))
    np.testing.assert_array_equal(back_to_front(np.zeros(5000), bits), np.arange(5000)[::-1])


def test_viewport_sort_puts_the_lower_global_index_in_front():
    from addon.core.viewport_sort import SortInput, visible_order

    pos = np.zeros((3000, 3), np.float32)
    l2c = np.eye(4)
    l2c[2, 3] = -3.0  # every centre at depth 3
    proj = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, -1.02, -0.2], [0, 0, -1.0, 0]])
    inputs = [SortInput.of(pos[:1000], l2c), SortInput.of(pos, l2c, cull=False)]
    order = visible_order(inputs, proj, 0.1, 100.0, 16).order
    np.testing.assert_array_equal(order, np.arange(4000)[::-1])


@pytest.mark.parametrize("gpu_sort", [True, False], ids=["gpu-radix", "cpu-sort"])
@pytest.mark.parametrize("bits", [16, 32])
def test_gl_sort_of_many_ties(gl, bits, gpu_sort):
    """6000 splats, three depths: the order the draw uses, read back from the GPU."""
    depth = _depths_with_ties()
    s = splats([RED] * depth.size, scales=(0.01, 0.01, 0.01))
    s.positions[:, 1] = depth - 4.0  # the camera is at y = -4 looking along +y
    gl.render([RenderItem(s)], camera(), RenderOptions(key_bits=bits, gpu_sort=gpu_sort))
    sort_depth = gl.last_depths()
    assert np.isfinite(sort_depth).all()
    np.testing.assert_array_equal(gl.last_order(), _expected(sort_depth, bits))
