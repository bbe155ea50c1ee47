"""Frame t is a pure function of the data and the property values at t (real bpy).

collect_items at frame 57 must be bitwise identical however the timeline got there: first
evaluation, after playing forwards, after scrubbing backwards, after a reload of the .blend;
and the render engine's frame 57 rendered alone equals frame 57 of an animation render.
"""
from __future__ import annotations

import numpy as np

from testing.animation_scene import add_object, grid_splats, items_at, snapshot
from testing.paths import REPO

FRAME = 57


def _keys(owner, name, pairs):
    for frame, value in pairs:
        setattr(owner, name, value)
        owner.keyframe_insert(name, frame=frame)


def build_scene(bpy):
    """Every effect type at once, time-dependent and keyframed, under a keyframed gizmo."""
    capture = add_object("capture", grid_splats(n_side=5, seed=3))
    other = add_object("other", grid_splats(n_side=4, seed=4), location=(0.3, 0.0, 0.2))
    other.splatline.look.visible = False  # a morph target that does not show itself
    _keys(other, "location", [(1, (0.3, 0.0, 0.2)), (100, (1.0, 0.5, 0.0))])
    gizmo = bpy.data.objects.new("gizmo", None)
    bpy.context.scene.collection.objects.link(gizmo)
    _keys(gizmo, "location", [(1, (0, 0, -1)), (100, (0, 0, 1))])
    effects = capture.splatline.effects
    specs = [
        ("REVEAL", {"reveal_shape": "NOISE", "glow_strength": 1.0, "gizmo": gizmo},
         ("progress", [(1, 0.0), (80, 1.0)])),
        ("DISPLACE", {"amplitude": 0.1, "speed": 1.5, "seed": 2}, ("amplitude", [(30, 0.0), (70, 0.2)])),
        ("EXPLODE", {"start_frame": 40.0, "spin": 2.0, "gravity": 1.0, "fade": 0.2}, None),
        ("TWIST", {"swirl": 1.0, "gizmo": gizmo}, ("twist", [(1, 0.0), (90, 2.0)])),
        ("GRADE", {"grade_field": "NOISE", "seed": 5}, ("amount", [(20, 0.0), (60, 0.8)])),
        ("MORPH", {"target": other}, ("amount", [(50, 0.0), (64, 1.0)])),
    ]
    for kind, values, keyed in specs:
        effect = effects.add()
        effect.type = kind
        for name, value in values.items():
            setattr(effect, name, value)
        if keyed:
            _keys(effect, *keyed)
    _keys(capture.splatline.look, "exposure", [(1, 0.0), (100, 1.0)])
    _keys(capture, "rotation_euler", [(1, (0, 0, 0)), (100, (0, 0, 1.0))])
    return capture


def state(bpy, frame):
    return [snapshot(item) for item in items_at(bpy, frame)]


def test_frame_57_is_the_same_however_we_get_there(bpy_empty, tmp_path):
    bpy = bpy_empty
    build_scene(bpy)
    first = state(bpy, FRAME)
    assert len(first) == 1, "the morph target is evaluated but not shown"
    assert state(bpy, FRAME - 1) != first, "the scene must change from frame to frame"
    for frame in range(1, 61):                 # play forwards through 57
        bpy.context.scene.frame_set(frame)
        if frame == FRAME:
            assert state(bpy, FRAME) == first
    for frame in range(100, FRAME, -3):        # scrub backwards onto it
        bpy.context.scene.frame_set(frame)
    assert state(bpy, FRAME) == first
    bpy.context.scene.frame_set(200)
    assert state(bpy, FRAME) == first
    path = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    assert state(bpy, FRAME) == first, "a fresh load (another farm node) sees the same frame"


def test_render_frame_57_alone_equals_it_inside_an_animation(bpy_empty, tmp_path, monkeypatch):
    from testing.engine_scene import add_camera, read_exr_parts, set_output, setup_render

    from addon.blender.render import engine

    bpy = bpy_empty
    build_scene(bpy)
    add_camera(bpy, location=(0.0, -6.0, 1.0))
    rendered = {}

    def spy(depsgraph, collect=engine.collect_items):
        items = collect(depsgraph)
        rendered.setdefault(depsgraph.scene.frame_current, []).append([snapshot(i) for i in items])
        return items
    scene = setup_render(bpy, 64, 48)
    set_output(scene, "EXR", tmp_path / "seq" / "frame_####")
    scene.frame_start, scene.frame_end = FRAME - 2, FRAME + 1
    monkeypatch.setattr(engine, "collect_items", spy)
    bpy.ops.render.render(animation=True)
    for frame in (90, 20):                      # scrub elsewhere, then render 57 alone
        scene.frame_set(frame)
    scene.frame_set(FRAME)
    set_output(scene, "EXR", tmp_path / "alone")
    bpy.ops.render.render(write_still=True)
    in_sequence = read_exr_parts(tmp_path / "seq" / f"frame_{FRAME:04d}.exr")["ViewLayer.Combined"]
    alone = read_exr_parts(tmp_path / "alone.exr")["ViewLayer.Combined"]
    before = read_exr_parts(tmp_path / "seq" / f"frame_{FRAME - 1:04d}.exr")["ViewLayer.Combined"]
    assert alone[..., 3].max() > 0.5, "the splats must be in view"
    assert np.abs(before - in_sequence).max() > 1e-3, "neighbouring frames differ"
    assert alone.tobytes() == in_sequence.tobytes()
    # the render's own depsgraph sees what the viewport's sees (the animated morph target too)
    assert rendered[FRAME][0] == rendered[FRAME][1] == state(bpy, FRAME)


def test_farm_split_frame_57_alone_in_another_process_matches(bpy_empty, tmp_path):
    """Two fresh processes, as on a farm: one renders 57 alone, one renders 55-58."""
    import subprocess
    import sys

    from testing.engine_scene import add_camera, read_exr_parts, setup_render

    bpy = bpy_empty
    build_scene(bpy)
    add_camera(bpy, location=(0.0, -6.0, 1.0))
    setup_render(bpy, 64, 48)
    bpy.context.scene.frame_set(12)  # the saved current frame must not matter
    blend = tmp_path / "farm.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    root = str(REPO)
    for out, frames in (("alone", "57"), ("range", "55-58")):
        done = subprocess.run([sys.executable, "-m", "addon", "render", str(blend), "--out",
                               str(tmp_path / out), "--frames", frames, "--format", "EXR"],
                              cwd=root, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    alone = read_exr_parts(tmp_path / "alone" / "frame_0057.exr")["ViewLayer.Combined"]
    ranged = read_exr_parts(tmp_path / "range" / "frame_0057.exr")["ViewLayer.Combined"]
    assert alone[..., 3].max() > 0.5
    assert alone.tobytes() == ranged.tobytes()
