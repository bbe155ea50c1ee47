"""The source table (addon/blender/data/sources.py): a throwaway source declared by its row
alone (testing/orbit_source.py: splats that turn by themselves) reaches the evaluator, the
viewport, Splatline's engine, the command line and Blender 5.3's handoff; and noise effects
stay attached to splats that move by themselves."""
from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from addon.blender.data import sources
from testing import orbit_source
from testing.capture_scenes import item_at, place
from testing.engine_paths_scene import reference_frame, render_exr, to_display
from testing.engine_scene import add_camera, read_image, set_output, setup_render
from testing.paths import REPO
from testing.viewport_scene import camera_for, draw_offscreen, overlay_drawn, psnr

RATE = 0.9  # radians a second: 24 fps, frame 12 is 0.45 rad on from frame 1
MIN_PSNR = 60.0  # the engine against the reference, as tests/blender/render/test_engine_paths.py


@pytest.fixture
def orbiting(bpy_empty):
    with sources.registered(orbit_source.ROW):
        yield bpy_empty


def _orbit_guitar(bpy, testdata):
    obj = place(bpy, testdata, "guitar.ply")  # its axes sit on the object as a rotation
    assert obj.rotation_euler[:] != (0.0, 0.0, 0.0)
    obj[orbit_source.PROPERTY] = RATE
    bpy.context.view_layer.update()
    return obj


def _expected(bpy, obj, frame):
    from addon.blender.data.pointcloud import splats_from_pointcloud

    seconds = frame / bpy.context.scene.render.fps
    return orbit_source.turned(splats_from_pointcloud(obj.data), RATE * seconds)


def test_a_throwaway_source_is_evaluated_from_its_row(orbiting, testdata):
    bpy = orbiting
    obj = _orbit_guitar(bpy, testdata)
    assert sources.source_of(obj) is orbit_source.ROW
    a, b = item_at(bpy, obj.name_full, 1), item_at(bpy, obj.name_full, 12)
    for frame, item in ((1, a), (12, b)):
        want = _expected(bpy, obj, frame)
        np.testing.assert_array_equal(item.splats.positions, want.positions)
        np.testing.assert_array_equal(item.splats.rotations, want.rotations)
    assert a.key != b.key and a.positions_key != b.positions_key
    again = item_at(bpy, obj.name_full, 12)
    assert again.key == b.key  # a pure function of the frame: the same key, the same splats
    from addon.blender.evaluate.items import stored_as_is
    from addon.blender.viewport.scene_items import time_dependent

    assert time_dependent(obj) and not obj.animation_data  # redrawn with no keyframe
    assert not stored_as_is(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()))
    del obj[orbit_source.PROPERTY]
    assert sources.source_of(obj).id == "STORED" and not time_dependent(obj)


def test_the_viewport_draws_each_frame_of_a_throwaway_source(orbiting, testdata):
    from addon.blender.viewport import ViewportRenderer
    from testing.headless import ensure_gpu

    bpy = orbiting
    obj = overlay_drawn(_orbit_guitar(bpy, testdata))
    ensure_gpu()
    viewport = ViewportRenderer()
    first = item_at(bpy, obj.name_full, 1)
    cam = camera_for(first.world[:3, 3], 96, 72)
    img1, _ = draw_offscreen([first], cam, renderer=viewport)
    later = item_at(bpy, obj.name_full, 12)
    img12, _ = draw_offscreen([later], cam, renderer=viewport)
    assert psnr(img1, img12) < 40.0  # the splats moved on screen
    assert psnr(img12, draw_offscreen([later], cam)[0]) == float("inf")  # as a fresh draw


def _orbit_scene(bpy, testdata, width=96, height=72):
    obj = _orbit_guitar(bpy, testdata)
    from addon.blender.data.pointcloud import splats_from_pointcloud

    local = splats_from_pointcloud(obj.data).positions.astype(np.float64)
    world = local @ np.array(obj.matrix_world)[:3, :3].T + np.array(obj.matrix_world)[:3, 3]
    centre = np.percentile(world, 50, axis=0)
    add_camera(bpy, location=tuple(centre + (0.0, -2.5, 0.6)), target=tuple(centre))
    return obj, setup_render(bpy, width, height)


def test_the_engine_renders_each_frame_of_a_throwaway_source(orbiting, testdata, tmp_path):
    bpy = orbiting
    _obj, scene = _orbit_scene(bpy, testdata)
    frames = {}
    for frame in (1, 12):
        scene.frame_set(frame)
        rgba, _depth, _ = render_exr(bpy, scene, tmp_path / f"f{frame}", "OFFSCREEN", depth=False)
        ref = reference_frame(bpy, scene)
        assert ref.rgba[..., 3].max() > 0.5
        assert psnr(to_display(rgba), ref.rgba) >= MIN_PSNR
        frames[frame] = ref.rgba
    assert psnr(frames[1], frames[12]) < 40.0


CLI_CHILD = textwrap.dedent("""
    import sys
    sys.path.insert(0, {root!r})
    from addon.blender.data import sources
    from testing import orbit_source
    sources.ROWS.insert(0, orbit_source.ROW)
    from addon.__main__ import main
    sys.exit(main(["render", {blend!r}, "--out", {out!r}, "--frames", "1-12",
                   "--format", "PNG"]))
""")


def test_the_command_line_renders_a_throwaway_source(orbiting, testdata, tmp_path):
    """The command line's frames of the orbiting capture: frame 12 is not frame 1, and
    equals what F12 writes for frame 12 in this process."""
    bpy = orbiting
    _obj, scene = _orbit_scene(bpy, testdata, 64, 48)
    blend = tmp_path / "orbit.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    out = tmp_path / "cli"
    code = CLI_CHILD.format(root=str(REPO), blend=str(blend), out=str(out))
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    written = sorted(out.glob("*.png"))
    assert len(written) == 12, [p.name for p in written]
    first, last = read_image(written[0]), read_image(written[-1])
    assert not np.array_equal(first, last)
    scene.frame_set(12)
    set_output(scene, "PNG", tmp_path / "f12")
    bpy.ops.render.render(write_still=True)
    np.testing.assert_array_equal(read_image(tmp_path / "f12.png"), last)


def test_a_noise_dissolve_stays_on_splats_that_move(orbiting, testdata):
    """Dissolve by noise at amount 1, progress 0.5: which splats are dissolved does not
    change while the source turns them; sampled at the moved centres it would."""
    from addon.core.effects import evaluate_stack
    from testing.effect_ops import add_effect

    bpy = orbiting
    obj = _orbit_guitar(bpy, testdata)
    add_effect(bpy, obj, "REVEAL", reveal_shape="NOISE", progress=0.5, edge_width=0.0,
               invert=True, frequency=4.0)
    a, b = item_at(bpy, obj.name_full, 1), item_at(bpy, obj.name_full, 12)
    gone_a, gone_b = a.splats.opacities == 0.0, b.splats.opacities == 0.0
    assert 0.2 < gone_a.mean() < 0.8
    np.testing.assert_array_equal(gone_a, gone_b)
    assert not np.array_equal(a.splats.positions, b.splats.positions)

    # the same stack sampled at the moved centres (no rest from the source) slides
    from testing.capture_scenes import frame_and_stack

    frame, stack, time = frame_and_stack(bpy, obj, b.world)
    slid = evaluate_stack(frame.splats, stack.params, time).splats.opacities == 0.0
    assert not np.array_equal(slid, gone_b)


def test_blender_53_draws_each_frame_of_a_throwaway_source(orbiting, testdata):
    """On 5.3 a capture imported by Blender's own wm.ply_import, with the orbit: the
    companion Blender's engines draw holds the turned splats at each frame."""
    from addon.blender.data import evaluated_geometry as geometry
    from addon.blender.data import native
    from addon.blender.data.pointcloud import splats_from_pointcloud

    bpy = orbiting
    if not native.has_native_splats():
        pytest.skip("this Blender has no native splats (PointCloud.type GAUSSIAN_SPLAT: 5.3+)")
    assert bpy.ops.wm.ply_import(filepath=str(testdata / "guitar.ply")) == {"FINISHED"}
    obj = bpy.context.view_layer.objects.active
    assert obj.data.type == "GAUSSIAN_SPLAT" and sources.is_splat_object(obj)
    obj[orbit_source.PROPERTY] = RATE
    seen = []
    for frame in (1, 12):
        bpy.context.scene.frame_set(frame)
        shown = splats_from_pointcloud(geometry.companion(obj).data)
        want = _expected(bpy, obj, frame)
        np.testing.assert_array_equal(shown.positions, want.positions)
        seen.append(shown.positions)
    assert not np.array_equal(*seen)
