"""stored_splats.BaseCache: edits of an animated capture reach the evaluated splats (no stale
frames), frame changes alone do not re-read it, and the viewport and a render thread can
share the cache."""
from __future__ import annotations

import sys
import threading

import numpy as np

from addon.blender.data import stored_splats
from addon.blender.evaluate import items as evaluate
from addon.blender.data.files import import_file
from addon.core.splats import SplatSet


def _item(bpy, obj, frame):
    bpy.context.scene.frame_set(frame)
    items = evaluate.collect_items(bpy.context.evaluated_depsgraph_get())
    return next(i for i in items if i.key[0] == obj.name_full)


def _reads(monkeypatch):
    calls = []
    real = stored_splats.splats_from_pointcloud
    monkeypatch.setattr(stored_splats, "splats_from_pointcloud",
                        lambda data, *a: calls.append(data.name) or real(data, *a))
    return calls


def test_editing_points_of_an_animated_capture_is_not_stale(bpy_empty, testdata, monkeypatch):
    bpy = bpy_empty
    obj = import_file(bpy.context, str(testdata / "test64.ply"))
    obj.keyframe_insert("location", frame=1)
    obj.location.z += 1.0
    obj.keyframe_insert("location", frame=20)
    reads = _reads(monkeypatch)
    before = _item(bpy, obj, 1).splats.positions.copy()
    for frame in (2, 3, 4):  # playing back re-reads nothing: the data did not change
        _item(bpy, obj, frame)
    assert len(reads) <= 1
    positions = obj.data.attributes["position"].data
    for index in (1, 2, 3):  # between the indices the 16-point sample looks at
        positions[index].vector = (5.0, 5.0, 5.0 + index)
    bpy.context.view_layer.update()
    after = _item(bpy, obj, 5).splats.positions
    np.testing.assert_allclose(after[1:4], [[5, 5, 6], [5, 5, 7], [5, 5, 8]])
    np.testing.assert_array_equal(np.delete(after, [1, 2, 3], 0), np.delete(before, [1, 2, 3], 0))


def test_prune_and_reads_on_two_threads(bpy_empty, monkeypatch):
    """The viewport (main thread) and a render thread both fill and prune the cache."""
    cache = stored_splats.BaseCache()
    tiny = SplatSet.allocate(1, 0)
    monkeypatch.setattr(stored_splats, "splats_from_pointcloud", lambda data: tiny.subset(np.arange(1)))
    monkeypatch.setattr(cache, "key", lambda obj, depsgraph: (("data", obj.name), obj.name, 0, 1, None, 0))

    class Fake:  # an evaluated object as get() sees it: key(), .data and no modifiers
        def __init__(self, name):
            self.name, self.data, self.modifiers = name, None, ()

    errors = []

    def fill(prefix):
        try:
            for i in range(3000):
                cache.get(Fake(f"{prefix}{i}"), None)
        except Exception as exc:  # noqa: BLE001 - the test reports whatever breaks
            errors.append(exc)

    def prune():
        try:
            for _ in range(3000):
                cache.prune()
        except Exception as exc:  # noqa: BLE001
            errors.append(exc)

    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=fill, args=("a",)), threading.Thread(target=prune),
                   threading.Thread(target=fill, args=("b",))]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(old)
    assert not errors, errors[:1]


def test_cache_key_follows_what_the_kernel_reads(bpy_empty, testdata):
    """Explode's start in seconds is start frame / fps: frame 48 at 24 fps and frame 96 at
    48 fps are the same time but different splats, so their keys must differ."""
    bpy = bpy_empty
    obj = import_file(bpy.context, str(testdata / "test64.ply"))
    effect = obj.splatline.effects.add()
    effect.type, effect.start_frame, effect.strength = "EXPLODE", 24.0, 1.0
    render = bpy.context.scene.render
    render.fps, render.fps_base = 24, 1.0
    slow = _item(bpy, obj, 48)
    render.fps = 48
    fast = _item(bpy, obj, 96)
    assert not np.array_equal(slow.splats.positions, fast.splats.positions)
    assert slow.key != fast.key


def test_a_store_during_prune_waits_for_it(bpy_empty, monkeypatch):
    """The race above made deterministic: prune is held in the middle of walking the entries
    while another thread stores one. With the lock the store waits until the walk is done;
    without it the walk breaks ("dictionary changed size during iteration")."""
    cache = stored_splats.BaseCache()
    tiny = SplatSet.allocate(1, 0)
    monkeypatch.setattr(stored_splats, "splats_from_pointcloud", lambda data: tiny.subset(np.arange(1)))
    monkeypatch.setattr(cache, "key", lambda obj, depsgraph: (("data", obj.name), obj.name, 0, 1, None, 0))
    walking, stored = threading.Event(), threading.Event()

    class Entries(dict):
        def __iter__(self):
            for i, key in enumerate(dict.__iter__(self)):
                if i == 0 and not walking.is_set():
                    walking.set()
                    stored.wait(0.5)  # long enough for a store the lock does not hold off
                yield key

    class Fake:
        def __init__(self, name):
            self.name, self.data, self.modifiers = name, None, ()

    cache.entries = Entries({("data", f"deleted{i}"): None for i in range(3)})
    errors = []

    def store():
        walking.wait(5)
        try:
            cache.get(Fake("new"), None)
        except Exception as exc:  # noqa: BLE001 - the test reports whatever breaks
            errors.append(exc)
        stored.set()

    writer = threading.Thread(target=store)
    writer.start()
    try:
        cache.prune()
    except RuntimeError as exc:
        errors.append(exc)
    writer.join()
    assert not errors, errors[:1]
    assert not cache.entries  # the deleted ones pruned, and "new" by its own get (no such data)
