"""Camera tracks (SuperSplat settings.json, document.json / .ssproj, frame lists) and the
default framing of a bare capture: pure numpy, no bpy.

The track's expected framing is computed here with PlayCanvas's own camera model
(splat-transform's render camera: forward = target - eye, right = forward x up, down =
forward x right, y up world) and a capture point p at Rz(180) p, independently of the code
that maps tracks into Blender."""
from __future__ import annotations

import json
import math
import zipfile

import numpy as np
import pytest

from addon.core import camtrack, framing
from addon.core.axes import matrix_for
from addon.core.camera import camera_from_params, rigid_inverse
from addon.core.errors import SplatFormatError
from testing.playcanvas_camera import H, SETTINGS, W, playcanvas_pixel


def blender_pixel(point_world, matrix, fov_deg, fit):
    """Pixel through a Blender camera at `matrix` whose lens gives `fov_deg` on `fit`."""
    lens = 18.0 / math.tan(math.radians(fov_deg) / 2)
    cam = camera_from_params(rigid_inverse(matrix), resolution_x=W, resolution_y=H, lens=lens,
                             sensor_width=36.0, sensor_height=36.0, sensor_fit=fit)
    return cam.project(np.asarray(point_world, float)[None])[0, :2]


def _write(tmp_path, data, name="track.json"):
    path = tmp_path / name
    path.write_text(json.dumps(data))
    return path


DOCUMENT = {"camera": {"fov": 60}, "timeline": {"frames": 90, "frameRate": 30},
            "poseSets": [{"name": "set0", "poses": [
                {"name": "a", "frame": 0, "position": [0, 1, 5], "target": [0, 1, 0], "fov": 45},
                {"name": "b", "frame": 60, "position": [4, 2, 0], "target": [0, 1, 0]}]}],
            "splats": [{"position": [0, 0, 0], "rotation": [0, 0, 1, 0], "scale": [1, 1, 1]}]}
FRAMES = {"frameRate": 25, "frames": [
    {"position": [0, 0, 4], "target": [0, 0, 0], "fov": 40},
    {"position": [3, 1, 3], "target": [0, 0.5, 0], "fov": 55, "up": [0, 1, 0]}]}


def test_settings_json(tmp_path):
    track = camtrack.read_track(_write(tmp_path, SETTINGS))
    assert track.shape == "settings.json" and track.frame_rate == 24 and track.fov_fit == "AUTO"
    assert [k.frame for k in track.keys] == [0, 24] and [k.fov for k in track.keys] == [50, 35]
    np.testing.assert_allclose(track.keys[1].position, [-5, 1, 1])
    np.testing.assert_allclose(track.keys[0].target, [0, 1.5, 0])
    assert track.last_frame == 24


def test_settings_v1_without_frame_rate_is_seconds_at_30fps(tmp_path):
    v1 = {"camera": {"fov": 42}, "animTracks": [{"name": "a", "duration": 1, "target": "camera",
          "loopMode": "none", "interpolation": "spline",
          "keyframes": {"times": [0, 1.5], "values": {"position": [0, 0, 3, 3, 0, 0],
                                                       "target": [0, 0, 0, 0, 0, 0]}}}]}
    track = camtrack.read_track(_write(tmp_path, v1))
    assert [k.frame for k in track.keys] == [0, 45] and track.frame_rate == 30
    assert [k.fov for k in track.keys] == [42, 42]  # v1: the settings' camera fov


def test_document_json_and_ssproj(tmp_path):
    path = _write(tmp_path, DOCUMENT, "document.json")
    track = camtrack.read_track(path)
    assert track.shape == "document.json" and track.frame_rate == 30
    assert [k.frame for k in track.keys] == [0, 60] and [k.fov for k in track.keys] == [45, 60]
    np.testing.assert_allclose(track.capture_to_playcanvas, camtrack.PLY_TO_PLAYCANVAS, atol=1e-12)
    project = tmp_path / "scene.ssproj"
    with zipfile.ZipFile(project, "w") as z:
        z.writestr("document.json", json.dumps(DOCUMENT))
        z.writestr("splat_0.ply", b"ply\n")
    from_zip = camtrack.read_track(project)
    assert [k.frame for k in from_zip.keys] == [0, 60]


def test_document_with_moved_capture(tmp_path):
    moved = json.loads(json.dumps(DOCUMENT))
    moved["splats"][0].update(position=[1, 2, 3], rotation=[0, 0, 0, 1], scale=[2, 2, 2])
    track = camtrack.read_track(_write(tmp_path, moved))
    np.testing.assert_allclose(track.capture_to_playcanvas,
                               [[2, 0, 0, 1], [0, 2, 0, 2], [0, 0, 2, 3], [0, 0, 0, 1]])


def test_frames_list(tmp_path):
    track = camtrack.read_track(_write(tmp_path, FRAMES))
    assert track.shape == "frames" and track.fov_fit == "VERTICAL" and track.frame_rate == 25
    assert [k.frame for k in track.keys] == [0, 1] and [k.fov for k in track.keys] == [40, 55]


@pytest.mark.parametrize("data", [SETTINGS, DOCUMENT, FRAMES], ids=["settings", "document", "frames"])
@pytest.mark.parametrize("axes, rotation_z", [("RDF", 0.0), ("RUB", 0.0), ("RDF", 0.7)])
def test_track_frames_capture_points_as_playcanvas_does(tmp_path, data, axes, rotation_z):
    """A capture point lands on the same pixel through the Blender camera as PlayCanvas
    draws it, for an object in any file convention, turned about z by the user."""
    track = camtrack.read_track(_write(tmp_path, data))
    turn = np.eye(4)
    c, s = math.cos(rotation_z), math.sin(rotation_z)
    turn[:2, :2] = [[c, -s], [s, c]]
    obj_matrix = turn.copy()
    obj_matrix[:3, :3] = turn[:3, :3] @ matrix_for(axes)  # object matrix: file -> world
    file_from_rdf = np.eye(4)
    file_from_rdf[:3, :3] = matrix_for(axes).T @ matrix_for("RDF")
    poses = camtrack.blender_poses(track, obj_matrix @ file_from_rdf)
    rng = np.random.default_rng(3)
    points_rdf = rng.uniform(-0.5, 0.5, (5, 3)) + [0, -1, 0]  # around the targets (y down)
    for key, (frame, matrix, fov) in zip(track.keys, poses):
        assert frame == key.frame and fov == key.fov
        for q in points_rdf:
            q_pc = (camtrack.PLY_TO_PLAYCANVAS @ np.append(q, 1))[:3]
            q_pc = (track.capture_to_playcanvas @ np.linalg.inv(camtrack.PLY_TO_PLAYCANVAS)
                    @ np.append(q_pc, 1))[:3]
            want = playcanvas_pixel(q_pc, key.position, key.target, key.up, key.fov, track.fov_fit)
            world = (obj_matrix @ file_from_rdf @ np.append(q, 1))[:3]
            got = blender_pixel(world, matrix, fov, track.fov_fit)
            np.testing.assert_allclose(got, want, atol=1e-6)


def test_playcanvas_up_is_blender_up_for_an_rdf_capture(tmp_path):
    """The mapping itself: PlayCanvas +y (up) is Blender +z for an unmoved RDF import."""
    track = camtrack.read_track(_write(tmp_path, FRAMES))
    rdf = np.eye(4)
    rdf[:3, :3] = matrix_for("RDF")
    (_, matrix, _), _ = camtrack.blender_poses(track, rdf)
    np.testing.assert_allclose(matrix[:3, 1], [0, 0, 1], atol=1e-12)  # camera up
    np.testing.assert_allclose(matrix[:3, 3], [0, 4, 0], atol=1e-12)  # PlayCanvas (0,0,4)


@pytest.mark.parametrize("content, reason", [
    (None, "no such file"),
    ("{not json", "not valid JSON"),
    ("[1, 2]", "expected a JSON object"),
    ('{"camera": {}}', "not a camera track"),
    ('{"frames": []}', "no keyframes"),
    ('{"animTracks": []}', "'animTracks' is empty"),
    ('{"poseSets": [{"poses": []}]}', "holds no camera poses"),
    ('{"frames": [{"position": [0, 0, 1], "target": [0, 0, 1]}]}', "the same point"),
    ('{"frames": [{"position": [0, 0], "target": [0, 0, 1]}]}', "frames[0].position: expected three"),
    ('{"frames": [{"target": [0, 0, 1]}]}', "missing field 'position'"),
    ('{"frames": [{"position": [0, 5, 0], "target": [0, 0, 0]}]}', "looks along its up"),
    ('{"frames": [{"position": [0, 0, 5], "target": [0, 0, 0], "fov": 0}]}', "fov"),
    ('{"frameRate": 0, "frames": [{"position": [0, 0, 5], "target": [0, 0, 0]}]}', "frameRate"),
    ('{"animTracks": [{"keyframes": {"times": [0], "values": {"position": [1, 2, 3], '
     '"target": [0, 0], "fov": [50]}}, "frameRate": 30}]}', "target: expected three"),
])
def test_bad_tracks_name_the_file_and_the_problem(tmp_path, content, reason):
    path = tmp_path / "bad.json"
    if content is not None:
        path.write_text(content)
    with pytest.raises(SplatFormatError) as info:
        camtrack.read_track(path)
    assert str(info.value).startswith(f"{path}: ") and reason in str(info.value)


def test_zip_without_document(tmp_path):
    path = tmp_path / "x.ssproj"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("other.json", "{}")
    with pytest.raises(SplatFormatError, match="no document.json"):
        camtrack.read_track(path)


def test_robust_bounds_ignore_floaters():
    rng = np.random.default_rng(0)
    subject = rng.uniform(-1, 1, (10_000, 3)) + [5, 0, 2]
    floaters = rng.uniform(-1, 1, (100, 3)) * 1000  # 1% far away
    bounds = framing.robust_bounds(np.concatenate([subject, floaters, [[np.nan] * 3]]))
    np.testing.assert_allclose(bounds.centre, [5, 0, 2], atol=0.1)
    assert 1.5 < bounds.radius < 1.8  # the subject's half diagonal is sqrt(3) = 1.73


def test_orbit_turns_once_round_the_centre_at_a_fitting_distance():
    bounds = framing.Bounds(np.array([1.0, 2, 3]), np.array([0.0, 1, 2]), np.array([2.0, 3, 4]))
    up, forward = framing.capture_axes("RDF", np.eye(4) @ _rdf())
    np.testing.assert_allclose([up, forward], [[0, 0, 1], [0, 1, 0]], atol=1e-12)
    distance = framing.fit_distance(bounds, 0.36, 0.2025)
    assert distance == pytest.approx(framing.MARGIN * math.sqrt(3) / math.sin(math.atan(0.2025)))
    poses = framing.orbit_poses(bounds, up, forward, distance, 8)
    np.testing.assert_array_equal(poses, framing.orbit_poses(bounds, up, forward, distance, 8))
    azimuths = []
    for m in poses:
        offset = m[:3, 3] - bounds.centre
        assert np.linalg.norm(offset) == pytest.approx(distance)
        np.testing.assert_allclose(-m[:3, 2], -offset / distance, atol=1e-12)  # looks at the centre
        assert math.degrees(math.asin(offset[2] / distance)) == pytest.approx(framing.ELEVATION_DEG)
        azimuths.append(math.atan2(offset[1], offset[0]))
    steps = np.diff(np.unwrap(azimuths))
    np.testing.assert_allclose(steps, 2 * math.pi / 8)  # counter-clockwise from above, one turn
    front = framing.front_pose(bounds, up, forward, distance)
    np.testing.assert_allclose(front[:3, 3], bounds.centre - [0, distance, 0])  # Blender's Front view
    np.testing.assert_allclose(front[:3, 1], [0, 0, 1], atol=1e-12)


def _rdf():
    m = np.eye(4)
    m[:3, :3] = matrix_for("RDF")
    return m
