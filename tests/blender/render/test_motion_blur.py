"""Motion blur: Blender's shutter settings -> sub-frame times (core/shutter.py), the
engine's sub-frame loop (blender/render/engine.py) against the reference, and farm
splits with motion blur on, in separate `python -m addon render` processes."""
from __future__ import annotations

import os

import numpy as np
import pytest

from addon.core import reference, shutter
from testing.engine_scene import add_camera, add_splats, flat_splats, read_exr_parts, set_output, setup_render
from testing.engine_scene import guitar_scene
from testing.cli_runs import render_all as _run_all


@pytest.fixture
def blur_blend(bpy_empty, testdata, tmp_path):
    """A guitar subset under a camera moving every frame (1-4), motion blur on, 32x24."""
    scene, _, _ = guitar_scene(bpy_empty, testdata, [1, 2, 3, 4], 32, 24, count=1000)
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 0.8
    path = tmp_path / "blur.blend"
    bpy_empty.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def test_sub_frame_times_by_hand():
    assert shutter.sub_frame_times(3, 1.0, "CENTER", 4) == [2.625, 2.875, 3.125, 3.375]
    assert shutter.sub_frame_times(3, 0.5, "START", 2) == [3.125, 3.375]
    assert shutter.sub_frame_times(3, 0.5, "END", 2) == [2.625, 2.875]
    assert shutter.split_time(2.625) == (2, 0.625) and shutter.split_time(-0.25) == (-1, 0.75)
    assert shutter.nearest_to_middle([2.625, 2.875, 3.125, 3.375]) == 1
    with pytest.raises(ValueError, match="position"):
        shutter.sub_frame_times(1, 0.5, "MIDDLE", 4)


def test_average_is_the_same_bits_in_any_process():
    frames = [np.random.default_rng(k).random((4, 5, 4)).astype(np.float32) for k in range(3)]
    a, b = shutter.Average(3), shutter.Average(3)
    for f in frames:
        a.add(f)
        b.add(f.copy())
    np.testing.assert_array_equal(a.result(), b.result())
    np.testing.assert_allclose(a.result(), np.mean(frames, axis=0), rtol=1e-6)
    with pytest.raises(RuntimeError, match="2 of 3"):
        c = shutter.Average(3)
        c.add(frames[0]), c.add(frames[1])
        c.result()


def _moving_splat_scene(bpy):
    obj = add_splats(bpy, "mover", flat_splats([(0.0, 0.0, 0.0)], [(0.9, 0.4, 0.1)], scale=0.1))
    for frame, x in ((1, -1.5), (5, 1.5)):
        obj.location = (x, 0.0, 0.0)
        obj.keyframe_insert("location", frame=frame)
    for fcurve in _fcurves(obj):
        for key in fcurve.keyframe_points:
            key.interpolation = "LINEAR"
    add_camera(bpy, location=(0.0, -8.0, 0.0))
    scene = setup_render(bpy, 96, 48)
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 1.0
    scene.render.motion_blur_position = "CENTER"
    scene.splatline.render.motion_blur_samples = 4
    return scene


def _fcurves(obj):
    action = obj.animation_data.action
    if hasattr(action, "fcurves") and len(action.fcurves):
        return list(action.fcurves)
    from bpy_extras import anim_utils  # 5.x slotted actions
    return list(anim_utils.action_get_channelbag_for_slot(action, obj.animation_data.action_slot).fcurves)


def _reference_film(bpy, scene, frame, subframe):
    from addon.blender.evaluate.items import collect_items
    from addon.blender.render.camera import camera_from_blender
    from addon.core.colorspace import premultiplied_srgb_to_linear as to_scene_linear

    scene.frame_set(frame, subframe=subframe)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    camera = camera_from_blender(scene, scene.camera, depsgraph)
    return to_scene_linear(reference.render(collect_items(depsgraph), camera).rgba)


def test_moving_splat_streak_matches_the_reference_average(bpy_empty, tmp_path):
    """Frame 3, shutter 1 frame centred, 4 samples: the engine's EXR equals the mean of
    reference renders at frames 2.625, 2.875, 3.125 and 3.375 (60 dB: GL vs float64)."""
    bpy = bpy_empty
    scene = _moving_splat_scene(bpy)
    scene.frame_start = scene.frame_end = 3
    set_output(scene, "EXR", tmp_path / "f_####")
    before = scene.frame_current
    bpy.ops.render.render(animation=True)
    got = read_exr_parts(tmp_path / "f_0003.exr")["ViewLayer.Combined"]
    assert scene.frame_current == before and scene.frame_subframe == 0.0  # the scene is put back
    want = np.mean([_reference_film(bpy, scene, f, s)
                    for f, s in ((2, 0.625), (2, 0.875), (3, 0.125), (3, 0.375))], axis=0)
    sharp = _reference_film(bpy, scene, 3, 0.0)
    mse = float(np.mean((got.astype(np.float64) - want) ** 2))
    assert 10 * np.log10(1.0 / max(mse, 1e-30)) >= 60.0
    columns = lambda img: np.count_nonzero(img[..., 3].max(0) > 0.01)  # noqa: E731
    assert columns(want) >= columns(sharp) + 6, "a streak, wider than the still splat"
    assert float(np.abs(got - sharp).max()) > 0.1


def test_farm_split_with_motion_blur_is_bit_identical(blur_blend, tmp_path):
    """1-4 in one process equals 3-4 and 1-2 in two others, bit for bit, motion blur on
    (a camera moving every frame); and the blur changes the frames."""
    blur = ("--engine-option", "motion_blur_samples=4")
    one, split, still = tmp_path / "one", tmp_path / "split", tmp_path / "still"
    _run_all([(blur_blend, "--out", one, "--format", "EXR", "--frames", "1-4", *blur),
              (blur_blend, "--out", split, "--format", "EXR", "--frames", "3-4", *blur),
              (blur_blend, "--out", split, "--format", "EXR", "--frames", "1-2", *blur),
              (blur_blend, "--out", still, "--format", "EXR", "--frames", "1-4",
               "--engine-option", "motion_blur_samples=1")])
    names = [f"frame_{f:04d}.exr" for f in range(1, 5)]
    assert sorted(os.listdir(one)) == sorted(os.listdir(split)) == names
    for name in names:
        a, b = read_exr_parts(one / name), read_exr_parts(split / name)
        for part in a:
            np.testing.assert_array_equal(a[part], b[part])
        c = read_exr_parts(still / name)["ViewLayer.Combined"]
        assert np.abs(a["ViewLayer.Combined"] - c).max() > 0.05, "motion blur was on"
