"""Rendering a bare capture: `render CAPTURE` (orbit, front, track), `import` adding a camera,
and File > Import > Splat Camera Track, in real bpy."""
from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from testing.paths import REPO as ROOT
from testing.engine_scene import read_image
from testing.playcanvas_camera import SETTINGS, playcanvas_pixel

from addon.core import formats
from addon.core.camtrack import PLY_TO_PLAYCANVAS
from addon.core.splats import SplatSet


def _cli(*args, timeout=300):
    return subprocess.run([sys.executable, "-m", "addon", *map(str, args)], cwd=ROOT,
                          capture_output=True, text=True, timeout=timeout)


def _alpha(path):
    return read_image(path)[..., 3].astype(np.float64) / 255.0


def _blob_capture(path, centre_rdf, count=200):
    """A small bright ball of splats round one point of the capture's RDF frame."""
    rng = np.random.default_rng(1)
    splats = SplatSet.allocate(count)
    splats.positions[:] = centre_rdf + rng.normal(0, 0.02, (count, 3))
    splats.scales[:] = 0.01
    splats.sh_dc[:] = 1.5
    formats.write(path, splats, "ply")
    return path


def test_render_guitar_spz_frames_the_capture(testdata, tmp_path):
    out = tmp_path / "out"
    # --axes RDF: splat-transform 3.7 wrote this .spz in the PLY's frame, not SPZ's RUB
    run = _cli("render", testdata / "guitar.spz", "--axes", "RDF", "--out", out, "--frames", "1-3",
               "--resolution", "320x180")
    assert run.returncode == 0, run.stdout + run.stderr
    frames = sorted(out.glob("frame_*.png"))
    assert [p.name for p in frames] == ["frame_0001.png", "frame_0002.png", "frame_0003.png"]
    alphas = [_alpha(p) for p in frames]
    for path, alpha in zip(frames, alphas):
        covered = alpha > 0.5
        rows, cols = np.nonzero(covered)
        h, w = alpha.shape
        # Measured 4.5-6.2%: the guitar is thin and upright in a 16:9 frame, so it fills the
        # height (below) and little of the width; 10% would need cropping its ends.
        assert 0.02 < covered.mean() < 0.9, (path, covered.mean())
        assert (rows.max() - rows.min()) / h > 0.6, path  # fills most of the height...
        border = np.concatenate([alpha[0], alpha[-1], alpha[:, 0], alpha[:, -1]])
        assert (border > 0.5).mean() < 0.02, path  # ...and is not cut off by the frame
        cy, cx = (np.average(np.mgrid[0:h, 0:w][i], weights=alpha) for i in (0, 1))
        assert abs(cx / w - 0.5) < 0.1 and abs(cy / h - 0.5) < 0.2, (path, cx / w, cy / h)
    assert not np.array_equal(alphas[0], alphas[1])  # the orbit moves


def test_render_capture_with_frames_track_lands_where_playcanvas_draws(tmp_path):
    """A synthetic track: the blob's pixel is computed with PlayCanvas's camera model."""
    blob_rdf = np.array([0.8, -0.5, 0.3])
    capture = _blob_capture(tmp_path / "blob.ply", blob_rdf)
    blob_pc = (PLY_TO_PLAYCANVAS @ np.append(blob_rdf, 1))[:3]  # (-0.8, 0.5, 0.3)
    keys = [{"position": [1.0, 1.5, 4.0], "target": [0.0, 1.0, 0.0], "fov": 30},
            {"position": [-3.0, 0.5, 2.0], "target": [0.2, 0.9, 0.0], "fov": 45}]
    track = tmp_path / "track.json"
    track.write_text(json.dumps({"frameRate": 24, "frames": keys}))
    out = tmp_path / "out"
    run = _cli("render", capture, "--out", out, "--camera", track, "--resolution", "320x180")
    assert run.returncode == 0, run.stdout + run.stderr
    frames = sorted(out.glob("frame_*.png"))
    assert len(frames) == 2  # the track's span sets the range
    for path, key in zip(frames, keys):
        alpha = _alpha(path)
        h, w = alpha.shape
        got = [np.average(np.mgrid[0:h, 0:w][i] + 0.5, weights=alpha) for i in (1, 0)]
        want = playcanvas_pixel(blob_pc, key["position"], key["target"], (0, 1, 0), key["fov"], "VERTICAL")
        assert 0 < want[0] < w and 0 < want[1] < h
        np.testing.assert_allclose(got, want, atol=1.5)
        assert abs(want[0] - w / 2) > 10 or abs(want[1] - h / 2) > 10  # off-centre: a real check


@pytest.mark.parametrize("camera, reason", [
    ("{missing}", "no such file"),
    ("{bad}", "not valid JSON"),
    ("{empty}", "no keyframes"),
])
def test_bad_track_is_one_line_and_writes_nothing(testdata, tmp_path, camera, reason):
    (tmp_path / "bad.json").write_text("{oops")
    (tmp_path / "empty.json").write_text('{"frames": []}')
    camera = camera.format(missing=tmp_path / "missing.json", bad=tmp_path / "bad.json",
                           empty=tmp_path / "empty.json")
    out = tmp_path / "out"
    run = _cli("render", testdata / "guitar.spz", "--out", out, "--camera", camera)
    errors = [line for line in run.stderr.splitlines() if line.startswith("error:")]
    assert run.returncode == 1 and len(errors) == 1, run.stderr
    assert errors[0].startswith(f"error: {camera}: ") and reason in errors[0]
    assert "Traceback" not in run.stderr and not out.exists()


def test_bad_capture_and_camera_on_blend_are_one_line(tmp_path):
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"not a ply")
    blend = tmp_path / "x.blend"
    blend.write_bytes(b"BLENDER")
    # bad data exits 1; a flag that does not apply to a .blend is a usage error, exit 2 (as
    # the framing flags on a .blend are)
    for args, reason, code in [((tmp_path / "none.ply",), "none.ply: no such file", 1),
                               ((bad,), "bad.ply: does not start like a .ply", 1),
                               ((blend, "--camera", "front"), "applies to a capture", 2),
                               ((blend, "--axes", "RUB"), "--axes RUB: applies to a capture", 2)]:
        run = _cli("render", *args, "--out", tmp_path / "out")
        assert run.returncode == code and reason in run.stderr and "Traceback" not in run.stderr, run.stderr
        assert not (tmp_path / "out").exists()


def test_import_adds_a_camera_that_frames_the_capture(bpy_empty, testdata, tmp_path):
    from addon.blender.render.camera import camera_from_blender
    from addon.blender.data.capture_camera import splat_world_points
    from addon.blender.data.pointcloud import read_opacities_scales_rotations
    from addon.core.visible_bounds import visible_bounds

    out = tmp_path / "g.blend"
    run = _cli("import", testdata / "guitar.ply", "--blend", out, "--max-count", "3000",
               "--camera", "front")
    assert run.returncode == 0, run.stderr
    bpy = bpy_empty
    bpy.ops.wm.open_mainfile(filepath=str(out))
    try:
        scene = bpy.context.scene
        assert scene.camera is not None and scene.camera.type == "CAMERA"
        guitar = bpy.data.objects["guitar"]  # turned by its axes, not scaled: scales as stored
        opacities, scales, _ = read_opacities_scales_rotations(guitar.data)
        bounds = visible_bounds(splat_world_points([guitar]), opacities, scales)  # the framing's box
        cam = camera_from_blender(scene, scene.camera, bpy.context.evaluated_depsgraph_get())
        u, v, depth = cam.project(np.array([bounds.centre, bounds.low, bounds.high])).T
        assert depth.min() > 0
        assert abs(u[0] - cam.width / 2) < 1e-6 * cam.width and abs(v[0] - cam.height / 2) < 1e-6 * cam.height
        assert ((0 <= u) & (u <= cam.width) & (0 <= v) & (v <= cam.height)).all()
    finally:
        bpy.ops.wm.read_factory_settings(use_empty=True)


def test_camera_track_operator(bpy_empty, tmp_path):
    """File > Import > Splat Camera Track keys a camera that follows a moved capture."""
    from addon.blender.render.camera import camera_from_blender
    from addon.blender.data.files import import_file

    bpy = bpy_empty
    assert any(getattr(f, "__name__", "") == "_menu_import" and "camera_track" in f.__module__
               for f in bpy.types.TOPBAR_MT_file_import._dyn_ui_initialize())
    obj = import_file(bpy.context, _blob_capture(tmp_path / "b.ply", np.array([0.0, -1.0, 0.0])))
    obj.rotation_euler.z += 0.6  # the user turned the capture: the track must turn with it
    obj.location = (1.0, -2.0, 0.5)
    bad = tmp_path / "bad.json"
    bad.write_text('{"frames": []}')
    before = set(bpy.data.objects)
    with pytest.raises(RuntimeError, match="bad.json: the track has no keyframes"):
        bpy.ops.import_scene.splatline_camera_track(filepath=str(bad))  # reported as an error
    assert set(bpy.data.objects) == before and not bpy.data.cameras
    track = tmp_path / "settings.json"
    track.write_text(json.dumps(SETTINGS))
    assert bpy.ops.import_scene.splatline_camera_track(filepath=str(track), start_frame=5) == {"FINISHED"}
    scene = bpy.context.scene
    assert (scene.frame_start, scene.frame_end, scene.render.fps) == (5, 29, 24)
    scene.render.resolution_x, scene.render.resolution_y = 320, 180
    bpy.context.view_layer.update()
    world = np.array(obj.matrix_world)
    points = np.random.default_rng(2).uniform(-0.4, 0.4, (4, 3)) + [0, -1, 0]  # RDF
    track_keys = SETTINGS["animTracks"][0]["keyframes"]
    for i, frame in enumerate((5, 29)):
        scene.frame_set(frame)
        cam = camera_from_blender(scene, scene.camera, bpy.context.evaluated_depsgraph_get())
        eye, target = track_keys["values"]["position"][3 * i:3 * i + 3], track_keys["values"]["target"][3 * i:3 * i + 3]
        for q in points:
            got = cam.project((world @ np.append(q, 1))[None, :3])[0, :2]
            want = playcanvas_pixel((PLY_TO_PLAYCANVAS @ np.append(q, 1))[:3], eye, target, (0, 1, 0),
                                    track_keys["values"]["fov"][i], "AUTO")
            np.testing.assert_allclose(got, want, atol=1e-3)
    assert math.isclose(scene.camera.data.sensor_width, 36.0)
