"""`python -m addon demo` end to end at a tiny size, as `make demo` runs it (a subprocess).

What the demo must leave behind: an editable demo.blend (two splat objects, the effect
stack, keyframed effects and camera), a half-float multilayer EXR sequence with alpha, an
H.264 MP4 of the same length whose colours are the EXRs' through the "Standard" view, and
a PNG still of one frame.
"""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from addon.core.colorspace import linear_to_srgb
from testing.paths import REPO as ROOT
from testing.engine_scene import read_exr_parts, read_image

FRAMES, WIDTH, HEIGHT, SPLATS = 6, 96, 54, 20000
LAYER = "ViewLayer.Combined"


def _run_demo(out, *extra):
    cmd = [sys.executable, "-m", "addon", "demo", "--frames", str(FRAMES),
           "--resolution", f"{WIDTH}x{HEIGHT}", "--out", str(out), *extra]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return proc.stdout


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    stdout = _run_demo(out, "--splats", str(SPLATS))
    return out, stdout


def _srgb_bytes(linear):
    """Scene-linear -> sRGB on a 0..255 scale, what the "Standard" view does (no dither)."""
    return linear_to_srgb(np.clip(linear, 0.0, 1.0)) * 255.0


def _exr_rgba(path):
    return read_exr_parts(path)[LAYER]


def _fcurves(obj, what="values"):
    """{(data_path, index): [key values]} (or key interpolations) of obj's action."""
    from bpy_extras import anim_utils

    anim = obj.animation_data
    assert anim is not None and anim.action is not None, f"{obj.name} has no animation"
    bag = anim_utils.action_get_channelbag_for_slot(anim.action, anim.action_slot)
    get = (lambda p: p.co[1]) if what == "values" else (lambda p: p.interpolation)
    return {(c.data_path, c.array_index): [get(p) for p in c.keyframe_points] for c in bag.fcurves}


def _varies(values) -> bool:
    return len(values) >= 2 and max(values) > min(values)


def test_prints_paths_and_time_per_frame(demo):
    out, stdout = demo
    for name in ("demo.blend", "demo.mp4", "demo.png", "exr"):
        assert str(out / name) in stdout
    assert "per frame" in stdout and "total" in stdout
    assert stdout.count(f"/{FRAMES})") == FRAMES  # one progress line per frame


def test_blend_reopens_with_objects_effects_and_keyframes(demo, bpy_empty):
    from addon.blender.data.sources import is_splat_object

    bpy = bpy_empty
    out, _ = demo
    bpy.ops.wm.open_mainfile(filepath=str(out / "demo.blend"))
    scene = bpy.context.scene
    assert scene.render.engine == "SPLATLINE"
    assert (scene.frame_start, scene.frame_end) == (1, FRAMES)
    source, target = bpy.data.objects["Capture"], bpy.data.objects["Morph Target"]
    assert is_splat_object(source) and is_splat_object(target)
    assert len(source.data.points) == SPLATS and len(target.data.points) == SPLATS
    assert "radiance:sh_14" in source.data.attributes  # degree 3 SH kept
    assert target.hide_render and not source.hide_render

    effects = source.splatline.effects
    assert [e.type for e in effects] == ["REVEAL", "DISPLACE", "MORPH", "REVEAL"]
    assert effects[2].target == target
    assert effects[0].glow_strength > 0 and effects[3].invert and effects[3].reveal_shape == "NOISE"
    curves = _fcurves(source)
    for index, prop in ((0, "progress"), (1, "amplitude"), (2, "amount"), (3, "progress")):
        keys = curves[(f'splatline.effects[{index}].{prop}', 0)]
        assert _varies(keys), (index, prop, keys)
    amplitude = curves[("splatline.effects[1].amplitude", 0)]
    assert amplitude[0] == amplitude[-1] == 0.0 and max(amplitude) > 0.0  # keyed up, then down
    # the sweeps run at constant speed; the swells ease in and out
    modes = _fcurves(source, "interpolation")
    assert set(modes[("splatline.effects[0].progress", 0)]) == {"LINEAR"}
    assert set(modes[("splatline.effects[1].amplitude", 0)]) == {"BEZIER"}
    amount = curves[("splatline.effects[2].amount", 0)]
    assert (amount[0], amount[-1]) == (0.0, 1.0)  # source at the start, target at the end

    camera = scene.camera
    assert camera is not None and not camera.constraints
    cam_curves = _fcurves(camera)
    assert all(_varies(cam_curves[("location", i)]) for i in range(3))
    assert any(_varies(cam_curves[("rotation_euler", i)]) for i in range(3))


def test_exr_sequence(demo):
    import OpenImageIO as oiio

    out, _ = demo
    files = sorted((out / "exr").glob("*.exr"))
    assert len(files) == FRAMES
    frames = []
    for path in files:
        spec = oiio.ImageInput.open(str(path)).spec()
        assert (spec.width, spec.height) == (WIDTH, HEIGHT)
        assert str(spec.format) == "half"
        rgba = _exr_rgba(path)
        assert rgba.shape == (HEIGHT, WIDTH, 4)
        frames.append(rgba)
    alphas = [f[..., 3] for f in frames]
    # transparent film: background at 0, the splats well above it somewhere mid-animation
    assert all(a.min() == 0.0 for a in alphas)
    assert max(a.max() for a in alphas) > 0.9
    # it moves: every frame differs from the next, and the middle frames show something
    assert all(np.abs(a - b).max() > 0.05 for a, b in zip(frames, frames[1:]))
    assert all(a.mean() > 0.01 for a in alphas[1:-1])


def _decode_movie(bpy, path, tmp_path):
    """Every frame of a movie as 8-bit RGB, read by Blender's own movie reader."""
    from addon.blender.demo import video as demo_video

    image = bpy.data.images.load(str(path))
    assert image.source == "MOVIE"
    count = image.frame_duration
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = image.size[:]
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    decoder = demo_video.encoding_scene(scene, str(path), count)
    try:
        frames = []
        for frame in range(1, count + 1):
            png = tmp_path / f"movie_{frame}.png"
            demo_video.still(decoder, frame, str(png))
            frames.append(read_image(png).astype(np.float64))
    finally:
        demo_video.remove_scene(decoder)
    return frames


def test_mp4_has_every_frame_in_the_exr_colours(demo, bpy_empty, tmp_path):
    bpy = bpy_empty
    out, _ = demo
    movie = bpy.data.images.load(str(out / "demo.mp4"))
    assert movie.source == "MOVIE"
    assert movie.frame_duration == FRAMES
    assert tuple(movie.size) == (WIDTH, HEIGHT)
    decoded = _decode_movie(bpy, out / "demo.mp4", tmp_path)
    exrs = sorted((out / "exr").glob("*.exr"))
    for frame, (pixels, exr) in enumerate(zip(decoded, exrs), start=1):
        expected = _srgb_bytes(_exr_rgba(exr)[..., :3])  # premultiplied: over black
        # H.264 is lossy (4:2:0 chroma, CRF "high"): per pixel it errs by 100+ levels at
        # sharp coloured edges of a 96x54 frame, so the checks are on whole frames. Measured
        # here: mean error <= 3.4 levels against >= 17 for the neighbouring frame (a frame
        # off by one), and the mean level within 0.5, against 9+ levels off where the
        # linear values are written without the sRGB curve.
        assert np.abs(pixels - expected).mean() < 6.0, frame
        assert abs(pixels.mean() - expected.mean()) < 2.0, frame


def test_png_still_is_the_showcase_frame(demo):
    from addon.blender.demo.scene import showcase_frame

    out, _ = demo
    still = read_image(out / "demo.png")
    assert still.shape == (HEIGHT, WIDTH, 3) and still.dtype == np.uint8
    frame = showcase_frame(FRAMES)
    expected = _srgb_bytes(_exr_rgba(out / "exr" / f"frame_{frame:04d}.exr")[..., :3])
    # the same pixels through the compositor: the 8-bit rounding of the half-float EXR
    # (half has 11 significant bits: under a third of a level after the sRGB curve)
    assert np.abs(still.astype(np.float64) - expected).max() <= 1.0
    assert still.mean() > 10.0


def test_file_replaces_the_knot(tmp_path, testdata, bpy_empty):
    bpy = bpy_empty
    count = 3000
    _run_demo(tmp_path, "--file", str(testdata / "guitar.spz"), "--splats", str(count))
    assert len(list((tmp_path / "exr").glob("*.exr"))) == FRAMES
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "demo.blend"))
    source, target = bpy.data.objects["guitar"], bpy.data.objects["Morph Target"]
    assert len(source.data.points) == count and len(target.data.points) == count * 3 // 4
    assert source.splatline.effects[2].target == target
    # the planet is sized to the capture: its radius is a fraction of the capture's extent
    from addon.blender.demo.scene import world_bounds

    extent = float(np.max(world_bounds(source).high - world_bounds(source).low))
    assert 0.2 * extent < target.scale[0] < extent


def test_bad_arguments_fail_with_one_line(tmp_path):
    # a bad option: usage, exit 2; a missing capture: data, exit 1
    for args, needle, code in ((["--frames", "3"], "--frames 3", 2), (["--resolution", "95x54"], "even", 2),
                               (["--file", str(tmp_path / "missing.ply")], "missing.ply", 1)):
        proc = subprocess.run([sys.executable, "-m", "addon", "demo", "--out", str(tmp_path), *args],
                              cwd=ROOT, capture_output=True, text=True, timeout=60)
        assert proc.returncode == code, proc.stderr
        assert needle in proc.stderr and "Traceback" not in proc.stderr


def test_saved_blend_renders_a_frame_alone_like_the_sequence(demo, tmp_path):
    """The farm story: demo.blend rendered for one frame by another process gives the same
    pixels as that frame of the demo's own sequence (frame t is a function of t alone)."""
    out, _ = demo
    frame = 4
    proc = subprocess.run([sys.executable, "-m", "addon", "render", str(out / "demo.blend"),
                           "--out", str(tmp_path), "--frames", str(frame)],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    alone = _exr_rgba(tmp_path / f"frame_{frame:04d}.exr")
    in_sequence = _exr_rgba(out / "exr" / f"frame_{frame:04d}.exr")
    assert alone.mean() > 0.0
    np.testing.assert_array_equal(alone, in_sequence)


def test_mp4_plays_in_ffmpeg(demo):
    """Decode every frame with ffmpeg itself (not Blender): a player-independent check that
    the file is a valid H.264 MP4 of the expected length and size."""
    import re
    import subprocess

    import imageio_ffmpeg

    out, _ = demo
    movie = out / "demo.mp4"
    proc = subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-stats", "-i", str(movie),
                           "-map", "0:v:0", "-f", "null", "-"], capture_output=True, text=True, timeout=60)
    # With -v error, anything on stderr besides the progress lines is a decode error.
    problems = [line for line in proc.stderr.replace("\r", "\n").splitlines()
                if line.strip() and "frame=" not in line]
    assert proc.returncode == 0 and not problems, proc.stderr
    frames = re.findall(r"frame=\s*(\d+)", proc.stderr)
    assert frames and int(frames[-1]) == FRAMES == len(list((out / "exr").glob("*.exr")))
    probe = subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-i", str(movie)],
                           capture_output=True, text=True, timeout=60).stderr
    assert re.search(rf"Video: h264.*\b{WIDTH}x{HEIGHT}\b", probe), probe
