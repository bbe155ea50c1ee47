"""blender/data/animation.py, the one F-curve/driver helper, on real bpy actions (layered on
every supported Blender): reading, interpolation and removal of keys and drivers."""
from __future__ import annotations

from testing.animation_scene import add_object, grid_splats


def _keyed_object(bpy):
    obj = add_object("keyed", grid_splats(2))
    effect = obj.splatline.effects.add()
    effect.type = "REVEAL"
    for frame, value in ((1, 0.0), (5, 0.5), (9, 1.0)):
        effect.progress = value
        obj.keyframe_insert("splatline.effects[0].progress", frame=frame)
    obj.keyframe_insert("location", frame=1)
    obj.driver_add("splatline.look.opacity")
    return obj


def test_channel_fcurves_are_the_action_curves_and_the_drivers(bpy_empty):
    from addon.blender.data.animation import action_fcurves, channel_fcurves

    obj = _keyed_object(bpy_empty)
    action = sorted((c.data_path, c.array_index) for c in action_fcurves(obj))
    assert action == [("location", 0), ("location", 1), ("location", 2),
                      ("splatline.effects[0].progress", 0)]
    every = sorted(c.data_path for c in channel_fcurves(obj))
    assert every.count("splatline.look.opacity") == 1 and len(every) == 5
    assert action_fcurves(add_object("bare", grid_splats(2))) == []


def test_set_interpolation_by_path_and_frame(bpy_empty):
    from addon.blender.data.animation import action_fcurves, set_interpolation

    obj = _keyed_object(bpy_empty)
    set_interpolation(obj, "CONSTANT", "splatline.effects[0].progress", frame=5)
    curves = {(c.data_path, c.array_index): c for c in action_fcurves(obj)}
    progress = curves[("splatline.effects[0].progress", 0)]
    assert [p.interpolation for p in progress.keyframe_points] == ["BEZIER", "CONSTANT", "BEZIER"]
    assert curves[("location", 0)].keyframe_points[0].interpolation == "BEZIER"
    set_interpolation(obj, "LINEAR")
    assert {p.interpolation for c in action_fcurves(obj) for p in c.keyframe_points} == {"LINEAR"}


def test_remove_fcurve_removes_a_driver_and_an_action_curve(bpy_empty):
    from addon.blender.data.animation import channel_fcurves, remove_fcurve

    obj = _keyed_object(bpy_empty)
    for path in ("splatline.look.opacity", "splatline.effects[0].progress"):
        remove_fcurve(obj, next(c for c in channel_fcurves(obj) if c.data_path == path))
    assert sorted(c.data_path for c in channel_fcurves(obj)) == ["location"] * 3


def test_orbit_camera_keys_are_linear(bpy_empty):
    """A key a frame: Blender's default Bezier would ease in and out of every frame."""
    from addon.blender.data.animation import action_fcurves
    from addon.blender.data.capture_camera import add_framing_camera

    bpy = bpy_empty
    obj = add_object("capture", grid_splats(3))
    bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 6
    camera = add_framing_camera(bpy.context, [obj], "orbit")
    points = [p for c in action_fcurves(camera) for p in c.keyframe_points]
    assert len(points) == 6 * 6 and {p.interpolation for p in points} == {"LINEAR"}
