"""The orbit camera's set-up is linear in the frame count (capture_camera.key_poses:
keyframe_points.add + foreach_set, not keyframe_insert a frame), with the same keys."""
from __future__ import annotations

import time

import numpy as np

from addon.core import framing


def _poses(count, start=1):
    rng = np.random.default_rng(3)
    bounds = framing.robust_bounds(rng.normal(size=(500, 3)))
    up, forward = np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])
    return list(zip(range(start, start + count), framing.orbit_poses(bounds, up, forward, 5.0, count)))


def _keys(camera):
    from addon.blender.data.animation import action_fcurves

    out = {}
    for c in action_fcurves(camera):
        co = np.empty(2 * len(c.keyframe_points), np.float32)
        c.keyframe_points.foreach_get("co", co)
        out[(c.data_path, c.array_index)] = co.reshape(-1, 2)
    return out


def test_key_poses_matches_keying_frame_by_frame(bpy_empty):
    from addon.blender.data import capture_camera as cc

    scene = bpy_empty.context.scene
    poses = _poses(60, start=7)
    slow = cc.new_camera(scene, "slow")
    for frame, matrix in poses:
        cc._key(slow, frame, matrix)
    fast = cc.new_camera(scene, "fast")
    cc.key_poses(fast, poses)
    want, got = _keys(slow), _keys(fast)
    assert set(want) == set(got) == {(p, i) for p in ("location", "rotation_euler") for i in range(3)}
    for key in want:
        np.testing.assert_allclose(got[key], want[key], atol=1e-5, err_msg=str(key))
    for frame in (7, 30, 66):  # and the evaluated camera agrees
        scene.frame_set(frame)
        np.testing.assert_allclose(np.array(fast.matrix_world), np.array(slow.matrix_world), atol=1e-5)


def test_orbit_of_20000_frames_sets_up_quickly(bpy_empty):
    from addon.blender.data import capture_camera as cc

    scene = bpy_empty.context.scene
    camera = cc.new_camera(scene)
    poses = _poses(20000)
    t0 = time.perf_counter()
    cc.key_poses(camera, poses)
    cc.set_interpolation(camera, "LINEAR")
    seconds = time.perf_counter() - t0
    keys = _keys(camera)
    assert all(len(v) == 20000 for v in keys.values())
    # keyframe_insert a frame took 17 s for 10000 frames (quadratic: ~70 s for 20000);
    # this is about a second on a shared 2-core machine
    assert seconds < 8.0, seconds
    print(f"orbit key set-up, 20000 frames: {seconds:.2f} s")
