"""CPU side of the viewport: radix order, culling, the global order, the sort worker (no bpy)."""
from __future__ import annotations

import time

import numpy as np
import pytest

from addon.core.clip_space import projection_matrix
from addon.core.viewport_sort import (LazyArray, SortInput, SortWorker, bounding_radius, centres_layout,
                                      visible_order)
from addon.core.camera import look_at, simple_camera
from addon.core.sort import back_to_front, depth_keys, far_to_near, radix_argsort


def test_radix_argsort_is_a_stable_sort():
    rng = np.random.default_rng(0)
    for dtype, top in ((np.uint16, 1 << 16), (np.uint32, 1 << 32)):
        keys = rng.integers(0, top, 20000, dtype=np.uint64).astype(dtype)
        keys[::7] = keys[3]  # plenty of ties
        assert np.array_equal(radix_argsort(keys), np.argsort(keys, kind="stable"))
    with pytest.raises(ValueError):
        radix_argsort(np.zeros(3, np.int64))


def _ties_descending(keys):
    """Ascending keys; equal keys in descending index (the lower index drawn last, in front)."""
    return np.lexsort((-np.arange(keys.size), keys))


@pytest.mark.parametrize("bits", [16, 32])
def test_far_to_near_matches_depth_keys(bits):
    rng = np.random.default_rng(1)
    depth = rng.uniform(5.0, 9.0, 5000).astype(np.float32)
    order = far_to_near(depth, bits)
    assert np.all(np.diff(depth[order].astype(np.float64)) <= 4.0 / (2 ** bits - 2) * 1.01)
    keys = depth_keys(depth, bits)
    if bits == 16:  # far_to_near rounds 16-bit keys in float32: one step off at some edges
        hi, lo = depth.max(), depth.min()
        own = ((hi - depth) * np.float32(65534 / (float(hi) - float(lo)))).astype(np.uint16)
        assert np.abs(own.astype(np.int64) - keys).max() <= 1
        keys = own
    assert np.array_equal(order, _ties_descending(keys))


@pytest.mark.parametrize("bits", [16, 32])
def test_back_to_front_is_the_stable_order_of_its_keys(bits):
    """The CPU sort of the GL renderer: radix passes, same order as a sort of the keys
    with ties in descending index, hidden and non-finite splats left out."""
    rng = np.random.default_rng(2)
    depth = rng.uniform(1.0, 50.0, 30000)
    depth[::5] = depth[1]  # ties: the lower index is drawn last
    depth[::11] = np.nan
    visible = rng.random(depth.size) > 0.2
    keys = depth_keys(depth, bits, visible)
    stable = _ties_descending(keys)
    expect = stable[(visible & np.isfinite(depth))[stable]]
    assert np.array_equal(back_to_front(depth, bits, visible), expect)
    stable = _ties_descending(depth_keys(depth, bits))
    assert np.array_equal(back_to_front(depth, bits), stable[np.isfinite(depth)[stable]])


def _camera():
    return simple_camera(200, 100, 60.0, look_at((0, -10, 0), (0, 0, 0)), near=0.5, far=40.0)


def test_culling_and_dilation():
    cam = _camera()
    half_w = np.tan(np.radians(30.0)) * 10.0  # half-width of the view at the origin's depth
    pts = np.array([[0, 0, 0], [1.1 * half_w, 0, 0], [1.5 * half_w, 0, 0], [0, -9.8, 0],
                    [0, 40.0, 0], [0, -9.0, 0.0]], np.float32)
    proj = projection_matrix(cam)
    tight = visible_order([SortInput.of(pts, cam.world_to_camera, True, 0.0)], proj, cam.near, cam.far)
    loose = visible_order([SortInput.of(pts, cam.world_to_camera, True, 0.2)], proj, cam.near, cam.far)
    off = visible_order([SortInput.of(pts, cam.world_to_camera, False)], proj, cam.near, cam.far)
    # 3: depth 0.2 < near; 4: depth 50 > far
    assert sorted(tight.order) == [0, 5]
    assert sorted(loose.order) == [0, 1, 5]
    assert sorted(off.order) == [0, 1, 2, 5]


def test_objects_interleave_in_one_order():
    """Two objects (one translated) sorted together, farthest first, global indices."""
    cam = _camera()
    a = np.array([[0, 0, 0], [0, 4, 0]], np.float32)       # depths 10, 14
    b = np.array([[0, 0, 0], [0, 2, 0]], np.float32)       # + (0, 1, 0): depths 11, 13
    world_b = np.eye(4)
    world_b[1, 3] = 1.0
    inputs = [SortInput.of(a, cam.world_to_camera), SortInput.of(b, cam.world_to_camera @ world_b)]
    result = visible_order(inputs, projection_matrix(cam), cam.near, cam.far, 16)
    assert list(result.order) == [1, 3, 2, 0]


def test_deferred_inputs_sort_as_their_arrays_and_are_made_once():
    """The viewport hands the sort its centres and radii as LazyArray (made on the sorting
    thread): the same order, culling by radius included, and each made on first use only."""
    cam = _camera()
    rng = np.random.default_rng(3)
    pts = rng.normal(0, 6, (20000, 3)).astype(np.float32)
    scales = np.exp(rng.uniform(-4, 0, (20000, 3))).astype(np.float32)
    proj = projection_matrix(cam)
    plain = SortInput(centres_layout(pts), cam.world_to_camera, True, 0.0, 1.0, bounding_radius(scales))
    made = []

    def counted(fn):
        return lambda a: made.append(fn.__name__) or fn(a)

    deferred = SortInput(LazyArray(counted(centres_layout), pts), cam.world_to_camera, True, 0.0, 1.0,
                         LazyArray(counted(bounding_radius), scales))
    assert made == []
    expect = visible_order([plain], proj, cam.near, cam.far)
    assert expect.radius_dependent, "the scene must cull by radius for this test to see it"
    for _ in range(2):
        got = visible_order([deferred], proj, cam.near, cam.far)
        np.testing.assert_array_equal(got.order, expect.order)
    assert sorted(made) == ["bounding_radius", "centres_layout"]
    assert deferred.radius.nbytes == 20000 * 4


def test_worker_returns_the_latest_request():
    cam = _camera()
    rng = np.random.default_rng(2)
    pts = rng.normal(0, 2, (50000, 3)).astype(np.float32)
    proj = projection_matrix(cam)
    done = []
    worker = SortWorker(on_done=lambda: done.append(1))
    try:
        views = [look_at((np.sin(t) * 10, -np.cos(t) * 10, 1), (0, 0, 0)) for t in (0.0, 0.5, 1.0)]
        for i, v in enumerate(views):
            worker.request(i, [SortInput.of(pts, v)], proj, cam.near, cam.far, 16)
        deadline = time.time() + 20
        result = None
        while time.time() < deadline:
            result = worker.take() or result
            if result is not None and result.token == 2 and worker.idle:
                break
            time.sleep(0.005)
        assert result is not None and result.token == 2
        expect = visible_order([SortInput.of(pts, views[2])], proj, cam.near, cam.far, 16)
        assert np.array_equal(result.order, expect.order)
        assert done
    finally:
        worker.stop()
    assert not worker.alive


def test_culling_keeps_a_large_splat_whose_body_covers_the_view():
    """Centre off-screen, 3-sigma sphere reaching into the view: kept; a small one: culled."""
    cam = _camera()
    half_w = np.tan(np.radians(30.0)) * 10.0
    pts = np.array([[2.0 * half_w, 0, 0], [2.0 * half_w, 0, 0]], np.float32)
    scales = np.array([[0.5 * half_w, 0.01, 0.01], [0.01, 0.01, 0.01]], np.float32)
    inp = SortInput.of(pts, cam.world_to_camera, True, 0.0, scales=scales)
    assert list(visible_order([inp], projection_matrix(cam), cam.near, cam.far).order) == [0]
    inp.radius_scale = 0.1  # the splat-scale multipliers shrink it out of view
    assert list(visible_order([inp], projection_matrix(cam), cam.near, cam.far).order) == []


def test_large_sets_cull_only_when_it_pays():
    """Above SMALL splats a sample decides: most off-screen -> culled, a few -> all kept
    (they would draw nothing anyway; culling them would cost more than drawing)."""
    from addon.core import viewport_sort as sorting

    cam = _camera()
    rng = np.random.default_rng(4)
    n = 20 * sorting.SMALL
    inside = rng.uniform(-0.5, 0.5, (n, 3)).astype(np.float32)
    far_out = inside + np.float32([100.0, 0.0, 0.0])
    proj = projection_matrix(cam)
    half = np.concatenate([inside[: n // 2], far_out[n // 2:]])
    order = visible_order([SortInput.of(half, cam.world_to_camera)], proj, cam.near, cam.far).order
    assert sorted(order) == list(range(n // 2))
    few = inside.copy()
    few[:n // 100] += np.float32([100.0, 0.0, 0.0])  # 1% outside: below CULL_WORTH
    order = visible_order([SortInput.of(few, cam.world_to_camera)], proj, cam.near, cam.far).order
    assert order.size == n
