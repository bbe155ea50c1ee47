"""Camera: the core projection against hand values, and camera_from_blender
against Blender's own projection (real bpy)."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.camera import camera_from_params, render_size, rigid_inverse

# Blender's projection matrix and object matrices are float32: relative error
# ~6e-8 on coordinates of up to ~1e3 px gives < 1e-4 px; 1e-3 px leaves margin.
PX_TOL = 1e-3


def test_defaults_match_hand_values():
    cam = camera_from_params(np.eye(4), resolution_x=1920, resolution_y=1080, percentage=50)
    assert (cam.width, cam.height) == (960, 540)
    assert cam.fx == pytest.approx(50.0 / 36.0 * 960)
    assert cam.fy == cam.fx and (cam.cx, cam.cy) == (480.0, 270.0)


def test_vertical_fit_shift_and_pixel_aspect_by_hand():
    cam = camera_from_params(np.eye(4), resolution_x=400, resolution_y=300, lens=35,
                             sensor_height=24, sensor_fit="VERTICAL", shift_x=0.1,
                             shift_y=-0.2, pixel_aspect_x=2.0, pixel_aspect_y=1.0)
    ycor = 0.5
    viewfac = ycor * 300  # a vertical fit spans the height, in aspect-corrected units
    assert cam.fx == pytest.approx(35 * viewfac / 24)
    assert cam.fy == pytest.approx(cam.fx / ycor)
    assert cam.cx == pytest.approx(200 - 0.1 * viewfac)
    assert cam.cy == pytest.approx(150 - 0.2 * viewfac / ycor)


def test_ortho_and_auto_fit_portrait():
    cam = camera_from_params(np.eye(4), resolution_x=300, resolution_y=600, ortho=True,
                             ortho_scale=4.0)
    assert cam.ortho and cam.fx == pytest.approx(600 / 4.0)  # AUTO fits the longer side
    u, v, depth = cam.project(np.array([[1.0, 0.5, -3.0]]))[0]
    assert (u, v, depth) == pytest.approx((150 + 150.0, 300 - 75.0, 3.0))


def test_bad_parameters_raise():
    with pytest.raises(ValueError):
        camera_from_params(np.eye(4), resolution_x=10, resolution_y=10, sensor_fit="DIAGONAL")
    with pytest.raises(ValueError):
        camera_from_params(np.eye(4), resolution_x=1, resolution_y=10, percentage=50)
    assert render_size(1001, 777, 33) == (330, 256)


def test_rigid_inverse_drops_scale():
    m = np.diag([2.0, 3.0, 0.5, 1.0])
    m[:3, 3] = (1, 2, 3)
    w2c = rigid_inverse(m)
    np.testing.assert_allclose(w2c[:3, :3], np.eye(3))
    np.testing.assert_allclose(w2c[:3, 3], (-1, -2, -3))


# --- against Blender ---------------------------------------------------------------

CASES = [
    # resolution x, y, %, pixel aspect x, y, fit, type, shift x, y
    (640, 480, 100, 1, 1, "AUTO", "PERSP", 0.0, 0.0),
    (480, 640, 50, 1, 1, "AUTO", "PERSP", 0.1, -0.2),
    (640, 480, 100, 2, 1, "VERTICAL", "PERSP", 0.3, 0.1),
    (640, 480, 100, 1, 1, "HORIZONTAL", "PERSP", -0.25, 0.4),
    (500, 490, 100, 1, 1.1, "AUTO", "PERSP", 0.0, 0.0),  # aspect flips AUTO to vertical
    (300, 500, 100, 1, 3, "HORIZONTAL", "ORTHO", 0.2, 0.4),
    (500, 300, 77, 3, 1, "AUTO", "ORTHO", 0.0, 0.3),
    (320, 240, 100, 1, 1, "VERTICAL", "ORTHO", -0.1, 0.0),
]


def _scene_camera(bpy, case):
    rx, ry, pct, ax, ay, fit, typ, sx, sy = case
    scene = bpy.context.scene
    data = bpy.data.cameras.new("cam")
    obj = bpy.data.objects.new("cam", data)
    scene.collection.objects.link(obj)
    scene.camera = obj
    obj.location = (1.0, -2.0, 3.0)
    obj.rotation_euler = (1.1, 0.2, 0.5)
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = rx, ry, pct
    r.pixel_aspect_x, r.pixel_aspect_y = ax, ay
    data.type, data.sensor_fit, data.shift_x, data.shift_y = typ, fit, sx, sy
    data.lens, data.sensor_width, data.sensor_height, data.ortho_scale = 42.0, 32.0, 20.0, 7.0
    data.clip_start, data.clip_end = 0.2, 80.0
    return scene, obj


def _points_in_view(obj, ortho, n=400):
    """World points spread over (and a little beyond) the view, at depths 0.5..30."""
    rng = np.random.default_rng(7)
    depth = rng.uniform(0.5, 30.0, n)
    spread = 4.0 if ortho else depth[:, None]
    local = np.c_[rng.uniform(-1.0, 1.0, (n, 2)) * spread, -depth, np.ones(n)]
    return (np.array(obj.matrix_world) @ local.T).T[:, :3]


def _blender_pixels(bpy, obj, depsgraph, width, height, ax, ay, points):
    """Pixel coordinates through Blender's own projection matrix."""
    proj = np.array(obj.calc_matrix_camera(depsgraph, x=width, y=height, scale_x=ax, scale_y=ay))
    view = np.linalg.inv(np.array(obj.matrix_world.normalized()))
    clip = proj @ view @ np.c_[points, np.ones(len(points))].T
    ndc = clip[:3] / clip[3]
    return np.stack([(ndc[0] + 1) / 2 * width, (1 - ndc[1]) / 2 * height], 1), ndc


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"{c[0]}x{c[1]}-{c[5]}-{c[6]}-asp{c[3]}:{c[4]}")
def test_matches_blender_projection_matrix(bpy_empty, case):
    from addon.blender.render.camera import camera_from_blender

    scene, obj = _scene_camera(bpy_empty, case)
    depsgraph = bpy_empty.context.evaluated_depsgraph_get()
    cam = camera_from_blender(scene, obj, depsgraph)
    assert (cam.width, cam.height) == render_size(case[0], case[1], case[2])
    assert (cam.near, cam.far) == pytest.approx((0.2, 80.0))
    points = _points_in_view(obj, case[6] == "ORTHO")
    theirs, ndc = _blender_pixels(bpy_empty, obj, depsgraph, cam.width, cam.height,
                                  case[3], case[4], points)
    ours = cam.project(points)
    near_view = np.all(np.abs(ndc[:2]) < 1.5, axis=0)
    assert near_view.sum() > 40  # the comparison covers many points
    np.testing.assert_allclose(ours[near_view, :2], theirs[near_view], atol=PX_TOL)


@pytest.mark.parametrize("case", [CASES[0], CASES[1], CASES[3], CASES[7]], ids=str)
def test_matches_world_to_camera_view(bpy_empty, case):
    from bpy_extras.object_utils import world_to_camera_view
    from mathutils import Vector

    from addon.blender.render.camera import camera_from_blender

    scene, obj = _scene_camera(bpy_empty, case)
    obj.scale = (2.0, 0.5, 3.0)  # Blender renders from the normalised matrix
    bpy_empty.context.view_layer.update()
    cam = camera_from_blender(scene, obj, bpy_empty.context.evaluated_depsgraph_get())
    points = _points_in_view(obj, case[6] == "ORTHO", n=60)
    ours = cam.project(points)
    for p, (u, v, depth) in zip(points, ours):
        x, y, z = world_to_camera_view(scene, obj, Vector(p))
        assert (u, v) == pytest.approx((x * cam.width, (1 - y) * cam.height), abs=PX_TOL)
        assert depth == pytest.approx(z, rel=1e-5)


def test_evaluated_animation_and_non_camera_object(bpy_empty):
    from addon.blender.render.camera import camera_from_blender

    scene, obj = _scene_camera(bpy_empty, CASES[0])
    obj.data.lens = 20.0
    obj.data.keyframe_insert("lens", frame=1)
    obj.data.lens = 80.0
    obj.data.keyframe_insert("lens", frame=11)
    scene.frame_set(11)
    cam = camera_from_blender(scene, obj, bpy_empty.context.evaluated_depsgraph_get())
    assert cam.fx == pytest.approx(80.0 * 640 / 32.0)

    empty = bpy_empty.data.objects.new("view", None)
    scene.collection.objects.link(empty)
    empty.location = (0.0, 0.0, 5.0)
    bpy_empty.context.view_layer.update()
    cam = camera_from_blender(scene, empty)
    assert cam.fx == pytest.approx(50.0 * 640 / 36.0)
    assert cam.position == pytest.approx((0.0, 0.0, 5.0))
