"""The Splatline RenderEngine through Blender's own render pipeline (real bpy, real files)."""
from __future__ import annotations

import threading

import numpy as np
import pytest

from addon.core.colorspace import linear_to_srgb
from testing.engine_scene import (add_camera, add_splats, exr_colour_formats, flat_splats, guitar_scene,
                          read_exr_parts, read_image, set_output, setup_render)

W, H = 160, 120


def test_png_with_standard_view_gives_the_capture_colour(bpy_empty, tmp_path):
    """A flat splat of DC colour c comes out of an 8-bit PNG as round(c * 255)."""
    bpy = bpy_empty
    # c * 255 stays >= 0.2 away from a rounding boundary, so a float32 path cannot flip it;
    # 5.2 lies on the linear segment of the sRGB curve, the others on the power segment.
    want_255 = np.array([[5.2, 100.8, 230.3], [17.7, 128.2, 250.9]])
    centres = [(-1.2, 0.0, 0.0), (1.2, 0.0, 0.0)]
    add_splats(bpy, "flat", flat_splats(centres, want_255 / 255.0, scale=0.35))
    add_camera(bpy, location=(0.0, -8.0, 0.0))
    scene = setup_render(bpy, 64, 32)
    set_output(scene, "PNG", tmp_path / "flat")
    bpy.ops.render.render(write_still=True)
    image = read_image(tmp_path / "flat.png")
    assert image.shape == (32, 64, 4) and image.dtype == np.uint8
    from addon.blender.render.camera import camera_from_blender

    uv = camera_from_blender(scene, scene.camera).project(np.array(centres))[:, :2]
    for (u, v), want in zip(uv, want_255):
        pixel = image[int(v), int(u)]
        np.testing.assert_array_equal(pixel[:3], np.round(want).astype(np.uint8))
        assert pixel[3] >= 250  # alpha 0.99 at the centre, a little less half a pixel off


def test_animation_writes_exr_sequence_and_mp4_of_guitar(bpy_empty, testdata, tmp_path):
    bpy = bpy_empty
    scene, centre, size = guitar_scene(bpy, testdata, [1, 2, 3], W, H, count=0)
    assert sum(len(o.data.points) for o in scene.objects if o.type == "POINTCLOUD") == 90854  # all of it
    set_output(scene, "EXR", tmp_path / "exr" / "guitar_####")
    bpy.ops.render.render(animation=True)
    set_output(scene, "MP4", tmp_path / "mp4" / "guitar_")
    bpy.ops.render.render(animation=True)

    exrs = sorted((tmp_path / "exr").glob("*.exr"))
    assert [p.name for p in exrs] == ["guitar_0001.exr", "guitar_0002.exr", "guitar_0003.exr"]
    frames = [read_exr_parts(p) for p in exrs]
    for parts in frames:
        rgba, depth = parts["ViewLayer.Combined"], parts["ViewLayer.Depth"][..., 0]
        assert rgba.shape == (H, W, 4) and depth.shape == (H, W)
        assert np.isfinite(rgba).all() and np.isfinite(depth).all()
        alpha = rgba[..., 3]
        assert alpha.min() >= 0.0 and alpha.max() <= 1.0
        assert 0.02 < (alpha > 0.5).mean() < 0.9, "the guitar should fill part of the frame"
        # Premultiplied: no colour without alpha; SH colours are clamped at 0 (not at 1).
        assert np.all(rgba[alpha == 0, :3] == 0) and rgba[..., :3].min() >= 0.0
        # A textured capture, not a flat fill: the straight display colour varies by more
        # than 0.03 (8 levels of 255) per channel; measured 0.04..0.2 here.
        covered = alpha > 0.5
        display = linear_to_srgb(rgba[covered, :3] / alpha[covered, None])
        assert display.std(axis=0).min() > 0.03
        # Depth (alpha-weighted) where the splats' alpha reaches 0.5, else the background.
        assert np.all(depth[alpha < 0.49] == 1e10)
        seen = depth[alpha > 0.51]
        cam_distance = np.hypot(1.1 * size, 0.1 * size)
        assert np.all((seen > cam_distance - size) & (seen < cam_distance + size))
    combined = [f["ViewLayer.Combined"] for f in frames]
    assert np.abs(combined[0] - combined[2]).mean() > 1e-3, "the camera moves between frames"

    movies = list((tmp_path / "mp4").glob("*.mp4"))
    assert [p.name for p in movies] == ["guitar_0001-0003.mp4"]
    movie = bpy.data.images.load(str(movies[0]))
    assert movie.source == "MOVIE" and movie.frame_duration == 3
    assert tuple(movie.size) == (W, H)
    first = np.array(movie.pixels[:], np.float32).reshape(H, W, 4)[::-1]  # bottom-up
    # Film is transparent and the video RGB: the premultiplied colour over black, through
    # the Standard view. H.264 (yuv420, chroma at half resolution) is lossy: 0.03 of mean
    # absolute error is about 8 levels of 255, far below the difference to a wrong frame.
    want = linear_to_srgb(np.clip(combined[0][..., :3], 0, 1))
    assert np.abs(first[..., :3] - want).mean() < 0.03
    assert np.abs(first[..., :3] - linear_to_srgb(np.clip(combined[2][..., :3], 0, 1))).mean() > \
        np.abs(first[..., :3] - want).mean()


def test_half_float_exr_matches_float(bpy_empty, tmp_path):
    bpy = bpy_empty
    add_splats(bpy, "s", flat_splats([(0, 0, 0), (0.4, 0.5, 0.2)], [(0.9, 0.3, 0.1), (0.1, 0.5, 0.9)]))
    add_camera(bpy)
    scene = setup_render(bpy, 48, 32)
    set_output(scene, "EXR", tmp_path / "full")
    bpy.ops.render.render(write_still=True)
    set_output(scene, "EXR", tmp_path / "half", half=True)
    bpy.ops.render.render(write_still=True)
    assert exr_colour_formats(tmp_path / "half.exr") == {"half"}
    full = read_exr_parts(tmp_path / "full.exr")["ViewLayer.Combined"]
    half = read_exr_parts(tmp_path / "half.exr")["ViewLayer.Combined"]
    assert full[..., 3].max() > 0.9
    # half keeps 11 significant bits: relative error <= 2^-11 (plus subnormals near 0).
    np.testing.assert_allclose(half, full, rtol=2.0 ** -11, atol=2.0 ** -24)


def _render_size(bpy, scene, tmp_path, name, engine):
    scene.render.engine = engine
    set_output(scene, "EXR", tmp_path / f"{name}_{engine}")
    bpy.ops.render.render(write_still=True)
    return read_exr_parts(tmp_path / f"{name}_{engine}.exr")["ViewLayer.Combined"]


def test_border_and_percentage_follow_blender(bpy_empty, tmp_path):
    """Output size and region as Cycles gives them; the border is a crop of the full frame."""
    bpy = bpy_empty
    add_splats(bpy, "s", flat_splats([(-1, 0, 0.3), (1.2, 0, -0.4)], [(0.9, 0.6, 0.2), (0.2, 0.5, 0.9)],
                                     scale=0.6))
    add_camera(bpy)
    scene = setup_render(bpy, 100, 60)
    scene.cycles.samples = 1
    full = _render_size(bpy, scene, tmp_path, "full", "SPLATLINE")
    assert full.shape == (60, 100, 4)

    scene.render.resolution_percentage = 50
    half = _render_size(bpy, scene, tmp_path, "pct", "SPLATLINE")
    assert half.shape == _render_size(bpy, scene, tmp_path, "pct", "CYCLES").shape == (30, 50, 4)

    scene.render.resolution_percentage = 100
    scene.render.use_border = True
    r = scene.render
    r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.13, 0.71, 0.25, 0.9
    ours = {}
    for crop in (True, False):
        r.use_crop_to_border = crop
        ours[crop] = _render_size(bpy, scene, tmp_path, f"crop{crop}", "SPLATLINE")
        assert ours[crop].shape == _render_size(bpy, scene, tmp_path, f"crop{crop}", "CYCLES").shape
    cropped, uncropped = ours[True], ours[False]
    # Blender: x0 = int(0.13 * 100) = 13, x1 = 71; y from the bottom int(0.25 * 60) = 15 .. 54.
    assert cropped.shape == (39, 58, 4)
    top, left = 60 - 54, 13
    # Same camera, principal point moved by whole pixels: the same splats at the same
    # sub-pixel positions. 1e-5 allows float32 rounding of the shifted coordinates.
    np.testing.assert_allclose(cropped, full[top:top + 39, left:left + 58], atol=1e-5)
    np.testing.assert_allclose(uncropped[top:top + 39, left:left + 58], cropped, atol=0)
    outside = np.ones(uncropped.shape[:2], bool)
    outside[top:top + 39, left:left + 58] = False
    assert np.all(uncropped[outside] == 0) and full[outside][:, 3].max() > 0.5


def test_frame_step_and_renderer_reused_across_frames(bpy_empty, tmp_path):
    from addon.blender.render import engine

    bpy = bpy_empty
    add_splats(bpy, "s", flat_splats([(0, 0, 0)], [(0.5, 0.5, 0.5)]))
    add_camera(bpy)
    scene = setup_render(bpy, 32, 24)
    scene.frame_start, scene.frame_end, scene.frame_step = 1, 5, 2
    set_output(scene, "PNG", tmp_path / "f_####")
    seen = []

    def after_frame(scene, *_):
        seen.append(engine._HOLDER._renderer)

    bpy.app.handlers.render_post.append(after_frame)
    try:
        bpy.ops.render.render(animation=True)
    finally:
        bpy.app.handlers.render_post.remove(after_frame)
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["f_0001.png", "f_0003.png", "f_0005.png"]
    assert len(seen) == 3 and seen[0] is not None and all(r is seen[0] for r in seen)
    assert not engine._HOLDER.alive, "closed when the job completes"


def test_no_thread_left_after_unregister(bpy_empty, tmp_path):
    from addon import register, unregister

    bpy = bpy_empty
    add_splats(bpy, "s", flat_splats([(0, 0, 0)], [(0.5, 0.5, 0.5)]))
    add_camera(bpy)
    scene = setup_render(bpy, 32, 24)
    before = set(threading.enumerate())
    set_output(scene, "PNG", tmp_path / "f")
    bpy.ops.render.render(write_still=True)
    unregister()
    try:
        left = [t for t in threading.enumerate() if t not in before and t.is_alive()]
        assert left == []
    finally:
        register()


def test_missing_camera_is_one_clear_error(bpy_empty):
    bpy = bpy_empty
    add_splats(bpy, "s", flat_splats([(0, 0, 0)], [(0.5, 0.5, 0.5)]))
    setup_render(bpy, 16, 16)
    with pytest.raises(RuntimeError, match="no camera"):
        bpy.ops.render.render()


PANELS_SINCE_5_0 = {"RENDER_PT_color_management_advanced",
                    "RENDER_PT_color_management_working_space", "VIEWLAYER_PT_context_layer"}


def test_blender_output_panels_show_for_the_engine(_bpy_registered):
    from addon import register, unregister
    from addon.blender.ui.render_panel import BUILTIN_PANELS

    bpy = _bpy_registered
    found = [getattr(bpy.types, name) for name in BUILTIN_PANELS if hasattr(bpy.types, name)]
    missing = {name for name in BUILTIN_PANELS if not hasattr(bpy.types, name)}
    # Only panels Blender 5.0 added may be absent (4.5): any other miss is a wrong name.
    assert missing <= PANELS_SINCE_5_0, missing
    assert all("SPLATLINE" in panel.COMPAT_ENGINES for panel in found)
    unregister()
    try:
        assert not any("SPLATLINE" in panel.COMPAT_ENGINES for panel in found)
    finally:
        register()


def test_no_splats_gives_an_empty_frame_and_hidden_objects_do_not_render(bpy_empty, tmp_path):
    bpy = bpy_empty
    add_camera(bpy)
    scene = setup_render(bpy, 32, 24)
    set_output(scene, "EXR", tmp_path / "empty")
    bpy.ops.render.render(write_still=True)
    empty = read_exr_parts(tmp_path / "empty.exr")
    assert np.all(empty["ViewLayer.Combined"] == 0)
    assert np.all(empty["ViewLayer.Depth"] == 1e10)

    add_splats(bpy, "shown", flat_splats([(0, 0, 0)], [(0.9, 0.1, 0.1)]))
    hidden = add_splats(bpy, "hidden", flat_splats([(0.3, -1, 0)], [(0.1, 0.9, 0.1)]))
    hidden.hide_render = True
    set_output(scene, "EXR", tmp_path / "one")
    bpy.ops.render.render(write_still=True)
    bpy.data.objects.remove(hidden)
    set_output(scene, "EXR", tmp_path / "alone")
    bpy.ops.render.render(write_still=True)
    one = read_exr_parts(tmp_path / "one.exr")["ViewLayer.Combined"]
    assert one[..., 3].max() > 0.9
    np.testing.assert_array_equal(one, read_exr_parts(tmp_path / "alone.exr")["ViewLayer.Combined"])


def test_each_view_layer_gets_its_own_splats(bpy_empty, tmp_path):
    bpy = bpy_empty
    # Apart on screen: 3 sigma is 6 px here, the centres are 25 px apart.
    add_splats(bpy, "a", flat_splats([(-1.5, 0, 0)], [(0.9, 0.1, 0.1)], scale=0.25))
    collection = bpy.data.collections.new("B")
    bpy.context.scene.collection.children.link(collection)
    b = add_splats(bpy, "b", flat_splats([(1.5, 0, 0)], [(0.1, 0.9, 0.1)], scale=0.25))
    bpy.context.scene.collection.objects.unlink(b)
    collection.objects.link(b)
    add_camera(bpy)
    scene = setup_render(bpy, 48, 32)
    scene.view_layers.new("OnlyA").layer_collection.children["B"].exclude = True
    set_output(scene, "EXR", tmp_path / "layers")
    bpy.ops.render.render(write_still=True)
    parts = read_exr_parts(tmp_path / "layers.exr")
    both, only_a = parts["ViewLayer.Combined"], parts["OnlyA.Combined"]
    assert "OnlyA.Depth" in parts
    left, right = np.s_[:, :24], np.s_[:, 24:]
    np.testing.assert_array_equal(only_a[left], both[left])
    assert both[right][..., 3].max() > 0.9 and only_a[right][..., 3].max() == 0.0


def _centroid(rgba):
    alpha = rgba[..., 3].astype(np.float64)
    ys, xs = np.mgrid[:alpha.shape[0], :alpha.shape[1]] + 0.5  # pixel centres
    return np.array([(alpha * xs).sum(), (alpha * ys).sum()]) / alpha.sum()


def test_stereo_renders_each_eye_from_its_own_camera(bpy_empty, tmp_path):
    """Off-axis stereo: eyes at -+b/2 with shifts converging at C. A splat at depth Z,
    on the axis, lands at u = W/2 -+ f b/2 (1/C - 1/Z) in the left and right images."""
    bpy = bpy_empty
    add_splats(bpy, "s", flat_splats([(0, 0, 0)], [(0.8, 0.5, 0.2)], scale=0.1))
    camera = add_camera(bpy, location=(0.0, -8.0, 0.0))
    scene = setup_render(bpy, 96, 64)
    scene.render.use_multiview = True
    scene.render.views_format = "STEREO_3D"
    stereo = camera.data.stereo
    stereo.convergence_mode, stereo.interocular_distance = "OFFAXIS", 0.5
    stereo.pivot = "CENTER"  # the default, LEFT, makes the camera the left eye
    stereo.convergence_distance = 4.0
    set_output(scene, "EXR", tmp_path / "eye")
    bpy.ops.render.render(write_still=True)
    left = read_exr_parts(tmp_path / "eye_L.exr")["ViewLayer.Combined"]
    right = read_exr_parts(tmp_path / "eye_R.exr")["ViewLayer.Combined"]
    f = 50.0 * 96 / 36.0  # lens * width / sensor width, in pixels
    half = f * 0.25 * (1 / 4.0 - 1 / 8.0)
    # The centroid of a sampled Gaussian (sigma 1.7 px) fully inside the frame is its
    # centre to far below 0.05 px; perspective skews a 0.1-unit splat by < 1e-3 px.
    np.testing.assert_allclose(_centroid(left), [48 - half, 32], atol=0.05)
    np.testing.assert_allclose(_centroid(right), [48 + half, 32], atol=0.05)


@pytest.mark.parametrize("transparent", [True, False], ids=["transparent", "world"])
def test_the_offscreen_renderers_film_is_the_engines_conversion(bpy_empty, testdata, tmp_path,
                                                                monkeypatch, transparent):
    """The offscreen renderer converts its frame itself (gl/film.py): the Combined pass it
    hands Blender is the one the engine's own conversion (film.result_rect) makes of the
    same frame, within the pow rounding tests/gl/test_film_pass.py allows. guitar.ply with
    its importer's axes, under an orbit camera; over a world colour or transparent."""
    from addon.gl import film

    bpy = bpy_empty
    scene, _, _ = guitar_scene(bpy, testdata, (1, 2), 96, 64, 20_000)
    scene.render.film_transparent = transparent
    if not transparent:
        scene.world = bpy.data.worlds.new("World")
        scene.world.color = (0.05, 0.2, 0.6)
    calls = []
    run = film.FilmPass.run
    monkeypatch.setattr(film.FilmPass, "run", lambda self, *a: calls.append(a) or run(self, *a))
    on_gpu = _render_size(bpy, scene, tmp_path, "film", "SPLATLINE")
    assert len(calls) == 1
    from addon.gl import OffscreenRenderer

    monkeypatch.setattr(OffscreenRenderer, "has_film", False)  # the engine's numpy conversion
    on_cpu = _render_size(bpy, scene, tmp_path, "numpy", "SPLATLINE")
    assert len(calls) == 1
    alpha = on_cpu[..., 3]
    assert (alpha == 1.0).all() if not transparent else (alpha == 0).any() and (alpha > 0.99).any()
    np.testing.assert_allclose(on_gpu, on_cpu, rtol=2e-6, atol=1e-7)
