"""A dynamic capture in real bpy: imported from a generated Spacetime-lite PLY (its RDF axes
on the object), it plays on the timeline, renders moving in Splatline's engine against the
float64 reference, follows a keyed capture time, renders a frame alone as in a range, and
on 5.3 reaches Blender's own engines (Cycles) through the handoff."""
from __future__ import annotations

import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from addon.core.dynamic import read_dynamic, write_dynamic
from addon.core.dynamic.reference import reference_at
from testing.capture_scenes import item_at
from testing.dynamic_scenes import KINDS, spacetime_capture
from testing.engine_paths_scene import render_exr, to_display
from testing.engine_scene import add_camera, read_image, set_output, setup_render
from testing.paths import REPO
from testing.viewport_scene import psnr

MIN_PSNR = 60.0  # the engine against the reference: tests/blender/render/test_engine_paths.py


@pytest.fixture
def capture():
    return spacetime_capture(2000)


def _import(bpy, capture, tmp_path, **options):
    from addon.blender.data.dynamic_files import import_dynamic

    path = tmp_path / "dancer.ply"
    write_dynamic(path, capture)
    obj = import_dynamic(bpy.context, path, **options)
    assert obj.rotation_euler[:] != (0.0, 0.0, 0.0)  # RDF on the object
    return obj


def _time(frame, start=1.0, per_unit=50.0):
    return (frame - start) / per_unit


def _expected(capture, t):
    """The reference's kept splats as a float32 SplatSet (the colours and scales are the
    capture's own: the time model does not change them)."""
    ref = reference_at(capture, t)
    rest = capture.rest().subset(ref.index)
    return replace(rest, positions=ref.positions.astype(np.float32),
                   rotations=ref.rotations.astype(np.float32),
                   opacities=ref.opacities.astype(np.float32)), ref.index


def test_a_dynamic_capture_plays_on_the_timeline(bpy_empty, tmp_path, capture):
    bpy = bpy_empty
    obj = _import(bpy, capture, tmp_path)
    dynamic = obj.splatline.dynamic
    assert (dynamic.enabled, dynamic.unit, dynamic.frames_per_unit) == (True, "SEGMENT", 50.0)
    assert dynamic.start_frame == bpy.context.scene.frame_start
    counts = []
    for frame in (1, 13, 26, 51):
        item = item_at(bpy, obj.name_full, frame)
        want, index = _expected(capture, _time(frame))
        assert item.splats.count == index.shape[0]
        np.testing.assert_allclose(item.splats.positions, want.positions, rtol=1e-5, atol=2e-6)
        np.testing.assert_allclose(item.splats.opacities, want.opacities, rtol=1e-5, atol=1e-7)
        np.testing.assert_allclose(np.abs(np.sum(item.splats.rotations * want.rotations, axis=1)),
                                   1.0, atol=1e-5)
        counts.append(item.splats.count)
    assert len(set(counts)) > 1  # splats fade in and out
    # a pure function of the frame: back to frame 13 gives the same key and splats
    again = item_at(bpy, obj.name_full, 13)
    np.testing.assert_array_equal(again.splats.positions, item_at(bpy, obj.name_full, 13).splats.positions)


def test_a_keyed_capture_time_freezes_then_reverses(bpy_empty, tmp_path, capture):
    bpy = bpy_empty
    obj = _import(bpy, capture, tmp_path)
    dynamic = obj.splatline.dynamic
    dynamic.use_capture_time = True
    for frame, t in ((1, 0.0), (10, 0.6), (20, 0.6), (30, 0.2)):
        dynamic.capture_time = t
        dynamic.keyframe_insert("capture_time", frame=frame)
    from addon.blender.data.animation import set_interpolation

    set_interpolation(obj, "LINEAR")
    expect = {5: 0.6 * 4 / 9, 12: 0.6, 18: 0.6, 25: 0.6 - 0.4 * 5 / 10}
    seen = {}
    for frame, t in expect.items():
        item = item_at(bpy, obj.name_full, frame)
        want, _ = _expected(capture, t)
        np.testing.assert_allclose(item.splats.positions, want.positions, rtol=1e-5, atol=2e-6)
        seen[frame] = item.splats.positions
    np.testing.assert_array_equal(seen[12], seen[18])  # frozen
    assert seen[5].shape != seen[25].shape or not np.array_equal(seen[5], seen[25])


def _scene(bpy, obj, width=96, height=72):
    world = np.array(obj.matrix_world)
    centre = world[:3, 3]
    add_camera(bpy, location=tuple(centre + (0.0, -3.2, 0.4)), target=tuple(centre))
    return setup_render(bpy, width, height)


def _reference_frame(bpy, scene, obj, capture, t):
    from addon.blender.render.camera import camera_from_blender
    from addon.core import reference
    from addon.core.scene import RenderItem

    want, _ = _expected(capture, t)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    item = RenderItem(splats=want, world=np.array(obj.matrix_world, np.float64), key=("ref", t))
    return reference.render([item], camera_from_blender(scene, scene.camera, depsgraph),
                            scene.splatline.render.options())


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_the_engine_renders_the_capture_moving(bpy_empty, tmp_path, kind):
    """Each representation read, through a render: Splatline's engine against the float64
    reference of the capture as read (a .splatv holds half floats) at the frame's time."""
    from addon.blender.data.dynamic_files import import_dynamic

    bpy = bpy_empty
    name, make = KINDS[kind]
    write_dynamic(tmp_path / name, make(2000))
    capture = read_dynamic(tmp_path / name)
    obj = import_dynamic(bpy.context, tmp_path / name)
    scene = _scene(bpy, obj)
    per_unit = obj.splatline.dynamic.frames_per_unit
    assert per_unit == (50.0 if capture.unit == "segment" else scene.render.fps)
    refs = {}
    for frame in (1, 26):
        scene.frame_set(frame)
        rgba, _depth, _ = render_exr(bpy, scene, tmp_path / f"f{frame}", "OFFSCREEN", depth=False)
        ref = _reference_frame(bpy, scene, obj, capture, _time(frame, per_unit=per_unit))
        assert ref.rgba[..., 3].max() > 0.3
        assert psnr(to_display(rgba), ref.rgba) >= MIN_PSNR
        refs[frame] = ref.rgba
    assert psnr(refs[1], refs[26]) < 35.0  # it moved


CLI = [sys.executable, "-m", "addon", "render"]


def test_frame_7_alone_is_frame_7_of_a_range(bpy_empty, tmp_path, capture):
    bpy = bpy_empty
    obj = _import(bpy, capture, tmp_path)
    _scene(bpy, obj, 48, 36)
    blend = tmp_path / "dyn.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    for frames, out in (("5-8", "range"), ("7-7", "alone")):
        done = subprocess.run(CLI + [str(blend), "--frames", frames, "--out", str(tmp_path / out),
                                     "--format", "PNG"], cwd=REPO, capture_output=True, text=True,
                              timeout=600)
        assert done.returncode == 0, done.stderr[-3000:]
    ranged, alone = sorted((tmp_path / "range").glob("*7.png")), sorted((tmp_path / "alone").glob("*.png"))
    assert len(ranged) == len(alone) == 1
    assert ranged[0].read_bytes() == alone[0].read_bytes()
    six = sorted((tmp_path / "range").glob("*6.png"))[0]
    assert not np.array_equal(read_image(six), read_image(ranged[0]))


def test_blender_53_renders_the_capture_moving_in_cycles(native_bpy, tmp_path, capture):
    """Cycles draws the handed-off frame: the colours of the capture, not black, and a
    sub-frame (the shutter's motion-blur samples) hands off its own capture time."""
    from addon.blender.data import evaluated_geometry as geometry
    from addon.blender.data.pointcloud import splats_from_pointcloud

    bpy = native_bpy
    obj = _import(bpy, capture, tmp_path)
    scene = _scene(bpy, obj, 40, 30)
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 4
    scene.cycles.device = "CPU"
    scene.render.film_transparent = True
    images = []
    for frame in (1, 26):
        scene.frame_set(frame)
        set_output(scene, "PNG", tmp_path / f"cycles{frame}")
        bpy.ops.render.render(write_still=True)
        image = read_image(tmp_path / f"cycles{frame}.png").astype(np.float64) / 255.0
        covered = image[..., 3] > 0.5
        assert covered.mean() > 0.02
        assert image[covered, :3].mean() > 0.15  # lit by its own colours, not black
        images.append(image)
    assert psnr(images[0], images[1]) < 35.0
    scene.frame_set(5, subframe=0.5)
    shown = splats_from_pointcloud(geometry.companion(obj).data)
    want, _ = _expected(capture, _time(5.5))
    np.testing.assert_allclose(shown.positions, want.positions, rtol=1e-5, atol=2e-6)


def test_the_look_and_effects_apply_to_the_moving_splats(bpy_empty, tmp_path, capture):
    """A Colour Grade and a Reveal on the dynamic object act on the frame's splats, exactly
    as their kernels on the source frame; the Look's opacity reaches the item."""
    from addon.core.effects import evaluate_stack
    from testing.capture_scenes import frame_and_stack
    from testing.effect_ops import add_effect

    bpy = bpy_empty
    obj = _import(bpy, capture, tmp_path)
    add_effect(bpy, obj, "GRADE")
    add_effect(bpy, obj, "REVEAL", progress=0.0, edge_width=0.2)
    obj.splatline.look.opacity = 0.7
    item = item_at(bpy, obj.name_full, 20)
    frame, stack, time = frame_and_stack(bpy, obj, item.world)
    want = evaluate_stack(frame.splats, stack.params, time, rest=frame.rest).splats
    for name in ("positions", "opacities", "sh_dc", "scales"):
        np.testing.assert_array_equal(getattr(item.splats, name), getattr(want, name))
    assert not np.array_equal(item.splats.sh_dc, frame.splats.sh_dc)  # graded
    assert (item.splats.opacities < frame.splats.opacities).any()  # revealed in part
    assert item.opacity_scale == pytest.approx(0.7)


def test_segment_files_import_as_one_object_that_plays_them_in_order(bpy_empty, tmp_path):
    """Spacetime's one file per 50 frames: two segments picked together are one object;
    frames 1-50 show the first file's splats, 51-100 the second's."""
    bpy = bpy_empty
    capture = spacetime_capture(800, segments=2)
    paths = [tmp_path / "seg_0.ply", tmp_path / "seg_1.ply"]
    write_dynamic(paths, capture)
    assert bpy.ops.import_scene.splatline_dynamic(
        directory=str(tmp_path), files=[{"name": p.name} for p in paths]) == {"FINISHED"}
    obj = bpy.context.view_layer.objects.active
    assert len(obj.data.points) == 1600 and obj.splatline.dynamic.time_end == 2.0
    for frame, t, segment in ((20, 19 / 50, 0), (70, 69 / 50, 1)):
        item = item_at(bpy, obj.name_full, frame)
        want, index = _expected(capture, t)
        assert np.all((index >= 800 * segment) & (index < 800 * (segment + 1)))
        np.testing.assert_allclose(item.splats.positions, want.positions, rtol=1e-5, atol=2e-6)
