"""The engine's two GPU paths (moderngl, Blender's gpu module) and its automatic fallback,
through bpy.ops.render.render, against the float64 reference.

PSNR bar, and why: the gpu-module path runs the viewport's shaders (the same
shaders/splat_math.glsl as moderngl) in float32, so it differs from the float64
reference by rounding plus rare discrete events (a pixel centre within rounding of a
quad edge or of the 1/255 cut, or a sort-key tie), exactly the error budget of
test_gl_render.py, plus the viewport's half-float splat data (shape, DC and SH rounded
to 11 significant bits, viewport/packing.py). Measured on this scene (160x120, Mesa
llvmpipe): moderngl 140.8 dB, gpu module 80.8 dB (139.5 dB with float32 data). 60 dB, as
for moderngl and the viewport, leaves room for other GPUs' rounding while any real bug
(wrong orientation, a missing colour-space conversion, a wrong blend or SH band) costs
more than 15 dB.
"""
from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from addon.blender.data.world import world_background
from addon.blender.render.film import BACKGROUND_DEPTH
from testing.engine_paths_scene import reference_frame, render_exr, to_display, two_object_scene
from testing.viewport_scene import psnr
from testing.paths import REPO

MIN_PSNR = 60.0


def test_both_paths_match_the_reference(bpy_empty, testdata, tmp_path):
    from addon.blender.render import backend as render_backend
    from addon.blender.ui.render_panel import path_text

    bpy = bpy_empty
    scene = two_object_scene(bpy, testdata)
    ref = reference_frame(bpy, scene)
    assert ref.rgba[..., 3].max() > 0.5
    gl, gl_depth, _ = render_exr(bpy, scene, tmp_path / "gl", "OFFSCREEN")
    assert render_backend.last_label().startswith("Offscreen GL (moderngl")
    gpu, gpu_depth, _ = render_exr(bpy, scene, tmp_path / "gpu", "GPU_MODULE")
    assert render_backend.last_label().startswith("Blender GPU module (")
    assert "Blender GPU module" in path_text("GPU_MODULE")
    # Same orientation and colour space: both are held to the reference, not to each other.
    assert psnr(to_display(gl), ref.rgba) >= MIN_PSNR
    assert psnr(to_display(gpu), ref.rgba) >= MIN_PSNR
    # moderngl has the depth pass; the gpu-module path writes the background value.
    assert np.isfinite(gl_depth).all() and (gl_depth < BACKGROUND_DEPTH).any()
    assert np.all(gpu_depth == BACKGROUND_DEPTH)


def test_auto_falls_back_when_no_gl_context(bpy_empty, testdata, tmp_path, monkeypatch, caplog):
    """An unknown glcontext backend fails as a missing driver does: the frame still renders."""
    from addon.blender.render import backend as render_backend

    bpy = bpy_empty
    monkeypatch.setenv("SPLATLINE_GL_BACKEND", "no-such-backend")
    monkeypatch.setattr(render_backend, "_logged", set())
    scene = two_object_scene(bpy, testdata, 96, 72)
    ref = reference_frame(bpy, scene)
    with caplog.at_level("WARNING", logger="splatline"):
        first, _, _ = render_exr(bpy, scene, tmp_path / "a", "AUTO")
        second, _, _ = render_exr(bpy, scene, tmp_path / "b", "AUTO")
    label = render_backend.last_label()
    assert label.startswith("Blender GPU module") and "fallback: no OpenGL context" in label
    assert "no-such-backend" in label
    assert psnr(to_display(first), ref.rgba) >= MIN_PSNR
    np.testing.assert_array_equal(second, first)
    logged = [r for r in caplog.records if "GPU module" in r.getMessage()]
    assert len(logged) == 1, "the reason is logged once, not per frame"


def test_forced_moderngl_fails_instead_of_falling_back(bpy_empty, testdata, tmp_path, monkeypatch):
    bpy = bpy_empty
    monkeypatch.setenv("SPLATLINE_GL_BACKEND", "no-such-backend")
    scene = two_object_scene(bpy, testdata, 32, 24)
    with pytest.raises(RuntimeError, match="OpenGL context"):
        render_exr(bpy, scene, tmp_path / "x", "OFFSCREEN")


def test_auto_falls_back_when_moderngl_is_not_installed(testdata, tmp_path):
    """A fresh process where `import moderngl` fails (a meta-path blocker), as on a
    platform without the wheel: Auto renders through Blender's gpu module."""
    root = str(REPO)
    script = textwrap.dedent(f"""
        import sys
        class Block:
            def find_spec(self, name, path=None, target=None):
                if name.split(".")[0] in ("moderngl", "glcontext"):
                    raise ImportError(f"No module named {{name!r}} (blocked)")
        sys.meta_path.insert(0, Block())
        sys.path.insert(0, {root!r})
        from testing.blender_packages import use_bundled_packages
        use_bundled_packages()
        import pathlib, bpy, numpy as np
        from addon import register
        bpy.ops.wm.read_factory_settings(use_empty=True)
        register()
        from testing.engine_paths_scene import reference_frame, render_exr, to_display, two_object_scene
        from testing.viewport_scene import psnr
        from addon.blender.render import backend as render_backend
        scene = two_object_scene(bpy, pathlib.Path({str(testdata)!r}), 96, 72)
        rgba, _, _ = render_exr(bpy, scene, pathlib.Path({str(tmp_path / "auto")!r}), "AUTO")
        assert "moderngl" not in sys.modules
        print("LABEL", render_backend.last_label())
        print("PSNR", psnr(to_display(rgba), reference_frame(bpy, scene).rgba))
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=300, cwd=str(tmp_path))
    assert done.returncode == 0, done.stderr[-3000:]
    lines = dict(line.split(" ", 1) for line in done.stdout.splitlines()
                 if line.startswith(("LABEL ", "PSNR ")))
    assert "fallback: moderngl not importable" in lines["LABEL"]
    assert float(lines["PSNR"]) >= MIN_PSNR
    assert "rendering through Blender's GPU module" in done.stderr  # logged, once
    assert done.stderr.count("rendering through Blender's GPU module") == 1


def test_gpu_path_percentage_border_and_world(bpy_empty, testdata, tmp_path):
    """What the moderngl path handles, through the gpu-module path: resolution
    percentage, border (a crop of the full frame), and the world under an opaque film."""
    bpy = bpy_empty
    scene = two_object_scene(bpy, testdata, 100, 60)
    full, _, _ = render_exr(bpy, scene, tmp_path / "full", "GPU_MODULE")
    assert full.shape == (60, 100, 4) and full[..., 3].max() > 0.5

    scene.render.resolution_percentage = 50
    half, _, _ = render_exr(bpy, scene, tmp_path / "half", "GPU_MODULE")
    assert half.shape == (30, 50, 4)
    assert psnr(to_display(half), reference_frame(bpy, scene).rgba) >= MIN_PSNR
    scene.render.resolution_percentage = 100

    r = scene.render
    r.use_border = True
    r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.13, 0.71, 0.25, 0.9
    r.use_crop_to_border = True
    cropped, _, _ = render_exr(bpy, scene, tmp_path / "crop", "GPU_MODULE")
    # Blender: x 13..71, y from the bottom 15..54 (test_engine.py works it out).
    assert cropped.shape == (39, 58, 4)
    # Against the reference of the region, not a crop of the full frame: every renderer
    # (reference included) clamps J to the region's frame plus 15 %, so splats far
    # outside the border differ from the full frame's (measured 0.024 at most here).
    assert psnr(to_display(cropped), reference_frame(bpy, scene).rgba) >= MIN_PSNR
    top, left = 60 - 54, 13
    r.use_crop_to_border = False
    uncropped, _, _ = render_exr(bpy, scene, tmp_path / "uncrop", "GPU_MODULE")
    np.testing.assert_array_equal(uncropped[top:top + 39, left:left + 58], cropped)
    outside = np.ones(uncropped.shape[:2], bool)
    outside[top:top + 39, left:left + 58] = False
    assert np.all(uncropped[outside] == 0) and full[outside][:, 3].max() > 0.1
    r.use_border = False

    scene.render.film_transparent = False
    world = scene.world = bpy.data.worlds.new("World")
    world.color = (0.9, 0.02, 0.4)
    want = np.asarray(world_background(world), np.float32)  # test_engine_world.py pins it
    assert want.max() > 0.0
    opaque, _, _ = render_exr(bpy, scene, tmp_path / "opaque", "GPU_MODULE")
    assert np.all(opaque[..., 3] == 1.0)
    np.testing.assert_allclose(opaque[..., :3], full[..., :3] + (1.0 - full[..., 3:]) * want,
                               rtol=1e-6, atol=1e-7)


def test_gpu_path_animation_reuses_one_renderer(bpy_empty, testdata, tmp_path):
    """Frames of one job share the renderer, each frame its own view; the job's end
    releases it. Its GPU textures live for one frame only: they must be freed inside
    render(), where Blender's GPU context is current (Blender 4.5 aborts otherwise)."""
    from addon.blender.render import engine
    from testing.engine_scene import orbit_keys, set_output

    bpy = bpy_empty
    scene = two_object_scene(bpy, testdata, 64, 48)
    scene.splatline.render.renderer = "GPU_MODULE"
    centre = tuple(np.array(scene.camera.location) - np.array([0.35, -0.9, 0.3]))
    orbit_keys(bpy, scene.camera, radius=0.9, height=0.3, frames=[1, 2, 3], target=centre)
    scene.frame_start, scene.frame_end = 1, 3
    set_output(scene, "EXR", tmp_path / "f_####")
    seen = []
    hook = lambda *_: seen.append(engine._HOLDER._renderer)
    bpy.app.handlers.render_post.append(hook)
    try:
        bpy.ops.render.render(animation=True)
    finally:
        bpy.app.handlers.render_post.remove(hook)
    assert len(seen) == 3 and all(r is seen[0] for r in seen)
    assert seen[0]._viewport.stats.uploads == 3 * 3, "pos, shape, sh: once a frame, freed in render()"
    assert seen[0]._viewport.gpu is None, "no GPU object outlives render()"
    assert not engine._HOLDER.alive
    from testing.engine_scene import read_exr_parts

    frames = [read_exr_parts(tmp_path / f"f_{k:04d}.exr")["ViewLayer.Combined"] for k in (1, 2, 3)]
    for frame, rgba in zip((1, 2, 3), frames):
        scene.frame_set(frame)
        assert psnr(to_display(rgba), reference_frame(bpy, scene).rgba) >= MIN_PSNR
    assert np.abs(frames[0] - frames[2]).mean() > 1e-3, "the camera moves"
