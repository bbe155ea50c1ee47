"""Splats and meshes in one frame, frame by frame: an animated mesh through
bpy.ops.render.render(animation=True), `python -m addon render` and a .blend opened as
`blender -b scene.blend -a` opens it.

The scene is mesh_layer_scene's guitar with the front cube moving across frames 1-3 and
the plane bending (a keyed shape key: new vertex positions, the same object matrix), so
the holdout's cache must see new geometry every frame. Frame 2 rendered alone equals
frame 2 of the range, bit for bit, in every pass and in the files; the frames differ from
each other, and from the same frames with Meshes set to Ignored.
"""
from __future__ import annotations

import os
import sys
import textwrap

import numpy as np
import pytest

from testing.engine_scene import read_exr_parts, read_image, set_output
from testing.mesh_layer_scene import build
from testing.cli_runs import render_command as _cli, run_all as _run_all
from testing.paths import REPO

ROOT = str(REPO)
W, H = 64, 48
COUNT = 6000
FRAMES = (1, 2, 3)


def animate(bpy, objects):
    """Front cube moving, plane bending (shape key), keyed on frames 1 and 3."""
    cube, plane = objects["front_cube"], objects["plane"]
    start = cube.location.copy()
    cube.keyframe_insert("location", frame=1)
    cube.location.x += 0.4 * cube.dimensions.x
    cube.location.z -= 0.3 * cube.dimensions.z
    cube.keyframe_insert("location", frame=3)
    cube.location = start
    plane.shape_key_add(name="Basis")
    bent = plane.shape_key_add(name="Bent")
    corner = bent.data[0].co
    normal = plane.data.polygons[0].normal
    bent.data[0].co = corner + 0.5 * plane.dimensions.length * normal
    bent.value = 0.0
    bent.keyframe_insert("value", frame=1)
    bent.value = 1.0
    bent.keyframe_insert("value", frame=3)


def animated_scene(bpy, testdata):
    hs, objects, _ = build(bpy, testdata, W, H, COUNT)
    animate(bpy, objects)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = FRAMES[0], FRAMES[-1]
    return scene, objects


def test_holdout_cache_follows_the_animation(bpy_empty, testdata):
    """holdout_for at each frame equals an uncached read of that frame, in any order."""
    from addon.blender.evaluate import holdout_geometry as hg

    bpy = bpy_empty
    scene, _ = animated_scene(bpy, testdata)
    hg.clear_cache()
    seen = {}
    for frame in (1, 2, 3, 2, 2, 1, 3):
        scene.frame_set(frame)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        holdout = hg.holdout_for(depsgraph)
        np.testing.assert_array_equal(holdout.triangles, hg.holdout_triangles(depsgraph))
        if frame in seen:
            assert holdout.key == seen[frame]
        seen[frame] = holdout.key
    assert len(set(seen.values())) == 3, "the geometry moves every frame"
    # a frame that repeats the last one gives the very same Holdout (no re-hash)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    assert hg.holdout_for(depsgraph) is hg.holdout_for(depsgraph)


def test_frame_alone_equals_frame_in_range(bpy_empty, testdata, tmp_path):
    bpy = bpy_empty
    scene, _ = animated_scene(bpy, testdata)
    set_output(scene, "EXR", tmp_path / "range" / "frame_####")
    bpy.ops.render.render(animation=True)
    scene.frame_start = scene.frame_end = 2
    set_output(scene, "EXR", tmp_path / "alone" / "frame_####")
    bpy.ops.render.render(animation=True)
    scene.splatline.render.meshes = "IGNORE"
    set_output(scene, "EXR", tmp_path / "ignored" / "frame_####")
    bpy.ops.render.render(animation=True)
    frames = [read_exr_parts(tmp_path / "range" / f"frame_{f:04d}.exr") for f in FRAMES]
    alone = read_exr_parts(tmp_path / "alone" / "frame_0002.exr")
    assert alone.keys() == frames[1].keys() >= {"Composite.Combined", "ViewLayer.Combined"}
    for part in alone:
        np.testing.assert_array_equal(alone[part], frames[1][part], err_msg=part)
    finals = [f["Composite.Combined"].tobytes() for f in frames]
    assert len(set(finals)) == 3, "the mesh moves every frame"
    splats = [f["ViewLayer.Combined"].tobytes() for f in frames]
    assert len(set(splats)) == 3, "and hides other splats every frame"
    ignored = read_exr_parts(tmp_path / "ignored" / "frame_0002.exr")
    assert "Composite.Combined" not in ignored
    assert not np.array_equal(ignored["ViewLayer.Combined"], alone["ViewLayer.Combined"])


# ---- the command line and a .blend opened headless ----

# `blender -b scene.blend -a`: the add-on is enabled before the file loads, then the
# scene's own range is rendered to its own output (RE_RenderAnim, as render(animation=True)).
OPEN_AND_RENDER = textwrap.dedent("""
    import sys
    sys.path.insert(0, {root!r})
    import bpy
    from addon import register
    bpy.ops.wm.read_factory_settings(use_empty=True)
    register()
    bpy.ops.wm.open_mainfile(filepath={blend!r})
    bpy.ops.render.render(animation=True)
""")


@pytest.fixture
def animated_blend(bpy_empty, testdata, tmp_path):
    """The animated scene saved with its engine on Workbench (no mesh layer set up): the
    command line must set it up itself; and a copy with Splatline as the engine, saved
    before any depsgraph update could set it up (the mesh layer comes on file load)."""
    from addon.blender.render import mesh_layer

    bpy = bpy_empty
    scene, _ = animated_scene(bpy, testdata)
    scene.render.engine = "BLENDER_WORKBENCH"
    bpy.context.view_layer.update()
    assert not mesh_layer.attached(scene)
    other = tmp_path / "workbench.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(other))
    scene.render.engine = "SPLATLINE"
    assert not mesh_layer.attached(scene)
    set_output(scene, "PNG", tmp_path / "opened" / "frame_####")
    scene.render.use_stamp_date = scene.render.use_stamp_render_time = False
    splatline = tmp_path / "splatline.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(splatline))
    return other, splatline


def test_cli_and_opened_blend_render_the_meshes(animated_blend, tmp_path):
    other, splatline = animated_blend
    runs = []
    for fmt in ("PNG", "EXR"):
        runs += [_cli(other, "--out", tmp_path / f"range_{fmt}", "--format", fmt, "--frames", "1-3"),
                 _cli(other, "--out", tmp_path / f"alone_{fmt}", "--format", fmt, "--frames", "2")]
    runs += [_cli(other, "--out", tmp_path / "ignored", "--format", "PNG", "--frames", "2",
                  "--engine-option", "meshes=IGNORE"),
             [sys.executable, "-c", OPEN_AND_RENDER.format(root=ROOT, blend=str(splatline))]]
    _run_all(runs)
    for fmt, ext in (("PNG", "png"), ("EXR", "exr")):
        names = [f"frame_{f:04d}.{ext}" for f in FRAMES]
        assert sorted(os.listdir(tmp_path / f"range_{fmt}")) == names
        alone, in_range = tmp_path / f"alone_{fmt}" / names[1], tmp_path / f"range_{fmt}" / names[1]
        assert alone.read_bytes() == in_range.read_bytes(), f"{fmt}: frame 2 alone == in 1-3"
    pngs = [read_image(tmp_path / "range_PNG" / f"frame_{f:04d}.png") for f in FRAMES]
    assert len({p.tobytes() for p in pngs}) == 3
    exr = read_exr_parts(tmp_path / "range_EXR" / "frame_0002.exr")
    assert {"Composite.Combined", "ViewLayer.Combined", "ViewLayer.Depth"} <= exr.keys()
    # the front cube (green) is in the frame, and not in the splats-only frame
    green = lambda img: ((img[..., 1].astype(int) > 2 * img[..., 0]) & (img[..., 1] > 2 * img[..., 2].astype(int))
                         & (img[..., 3] > 250)).sum()
    assert green(pngs[1]) > 30
    assert green(read_image(tmp_path / "ignored" / "frame_0002.png")) == 0
    # the .blend opened headless (load_post sets the mesh layer up) gives the CLI's frames
    for f in FRAMES:
        opened = read_image(tmp_path / "opened" / f"frame_{f:04d}.png")
        np.testing.assert_array_equal(opened, pngs[f - 1])
