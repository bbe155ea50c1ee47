"""The GL 3.3 path projects a large item a block at a time (so a stop is seen between blocks):
its records are those of one projection of the whole item, value for value."""
from __future__ import annotations

import numpy as np

from addon.core.camera import look_at, simple_camera
from addon.core.scene import RenderItem, RenderOptions
from addon.gl import fallback
from testing.synth import random_splats


def test_blocked_records_equal_one_projection(monkeypatch):
    s = random_splats(5000, degree=2, seed=3)
    item = RenderItem(splats=s, world=np.eye(4), key=("b", 0))
    camera = simple_camera(160, 90, 50.0, look_at(np.array([0.0, -20.0, 3.0]), np.zeros(3)))
    whole = fallback._item_records(item, camera, RenderOptions())
    monkeypatch.setattr(fallback, "_BLOCK", 777)  # 7 blocks, the last one short
    blocked = fallback._item_records(item, camera, RenderOptions())
    np.testing.assert_array_equal(blocked, whole)
    assert np.isfinite(whole[1, :, 2]).sum() > 100  # splats in view


def test_blocked_gather_equals_one_gather(monkeypatch):
    rec = np.random.default_rng(5).normal(size=(3, 2500, 4))
    order = np.random.default_rng(6).permutation(2500)[:2100]
    monkeypatch.setattr(fallback, "_BLOCK", 600)
    np.testing.assert_array_equal(fallback._gathered(rec, order), rec[:, order].astype(np.float32))


def test_a_stop_between_blocks_ends_the_projection(monkeypatch):
    import pytest

    from addon.core import stop

    s = random_splats(3000, degree=0, seed=4)
    item = RenderItem(splats=s, world=np.eye(4), key=("b", 1))
    camera = simple_camera(64, 64, 50.0, look_at(np.array([0.0, -20.0, 0.0]), np.zeros(3)))
    monkeypatch.setattr(fallback, "_BLOCK", 1000)
    stop.request_stop()
    try:
        with pytest.raises(stop.Stopped):
            fallback._item_records(item, camera, RenderOptions())
    finally:
        stop.clear_stop()
