"""Every bundled render-output preset applies and sets what its name promises: checked on the
scene settings and on the file a real render through the Splatline engine writes."""
from __future__ import annotations

import pytest

import numpy as np
from testing.engine_scene import add_camera, add_splats, exr_colour_formats, flat_splats, setup_render

from addon.blender.data import presets
from addon.blender.compat import media_type

EXPECT = {
    "exr_half_multilayer": dict(media_type="MULTI_LAYER_IMAGE", file_format="OPEN_EXR_MULTILAYER",
                                color_depth="16", ext=".exr", pixel="half"),
    "exr_float": dict(media_type="IMAGE", file_format="OPEN_EXR", color_depth="32", ext=".exr",
                      pixel="float"),
    "png_16bit": dict(media_type="IMAGE", file_format="PNG", color_depth="16", ext=".png",
                      pixel="uint16"),
    "h264_mp4": dict(media_type="VIDEO", file_format="FFMPEG", codec="H264", ext=".mp4",
                     fourcc=b"avc1"),
    "prores_422": dict(media_type="VIDEO", file_format="FFMPEG", codec="PRORES", ext=".mov",
                       fourcc=b"apch"),  # ProRes 422 HQ's sample-entry tag
    "preview": dict(media_type="IMAGE", file_format="PNG", percentage=50, key_bits="16",
                    ext=".png", pixel="uint8"),
}


def test_every_bundled_preset_is_covered(bpy_empty):
    assert set(presets.list_presets("render")) == set(EXPECT)


@pytest.mark.parametrize("name", sorted(EXPECT))
def test_preset_sets_scene(bpy_empty, name):
    bpy = bpy_empty
    scene = bpy.context.scene
    scene.render.resolution_percentage = 100
    presets.apply_render_preset(name)
    want, image = EXPECT[name], scene.render.image_settings
    assert media_type(image) == want["media_type"]
    assert image.file_format == want["file_format"]
    if "color_depth" in want:
        assert image.color_depth == want["color_depth"]
    if "codec" in want:
        assert scene.render.ffmpeg.codec == want["codec"]
    if "percentage" in want:
        assert scene.render.resolution_percentage == want["percentage"]
    if "key_bits" in want:
        assert scene.splatline.render.key_bits == want["key_bits"]
    if name == "exr_half_multilayer":
        assert all(layer.use_pass_z for layer in scene.view_layers)


def test_find_preset_by_display_name_and_error(bpy_empty):
    assert presets.find_preset("H264 MP4").stem == "h264_mp4"
    with pytest.raises(KeyError, match="choose from"):
        presets.find_preset("no such preset")


W, H = 64, 48


@pytest.mark.parametrize("name", sorted(EXPECT))
def test_preset_render_writes_its_file_type(bpy_empty, tmp_path, name):
    """Two frames through the Splatline engine with only the preset choosing the output."""
    bpy = bpy_empty
    add_splats(bpy, "splats", flat_splats([(0, 0, 0), (0.6, 0.5, 0.2)], [(0.8, 0.3, 0.1), (0.1, 0.5, 0.9)]))
    add_camera(bpy, location=(0.0, -6.0, 0.0))
    scene = setup_render(bpy, W, H)
    scene.frame_start, scene.frame_end = 1, 2
    presets.apply_render_preset(name)
    scene.render.filepath = str(tmp_path / "out_")
    bpy.ops.render.render(animation=True)
    want = EXPECT[name]
    files = sorted(tmp_path.glob("out_*"))
    assert files and all(f.suffix == want["ext"] for f in files), files
    scale = want.get("percentage", 100) / 100
    if "fourcc" in want:
        (movie,) = files
        assert want["fourcc"] in movie.read_bytes()
        clip = bpy.data.images.load(str(movie))
        assert clip.source == "MOVIE" and clip.frame_duration == 2
        assert tuple(clip.size) == (W, H)
        return
    import OpenImageIO as oiio

    assert len(files) == 2
    specs = _part_specs(oiio, files[0])
    spec = specs[0]
    assert (spec.width, spec.height) == (int(W * scale), int(H * scale))
    assert exr_colour_formats(files[0]) == {want["pixel"]}
    names = [n for part in specs for n in part.channelnames]
    assert any(n.endswith("A") for n in names)
    if name == "exr_half_multilayer":
        assert any(n.endswith(("Depth.Z", "Z")) for n in names), names
    pixels = oiio.ImageBuf(str(files[0])).get_pixels(oiio.FLOAT)
    assert np.isfinite(pixels).all() and pixels[..., :3].max() > 0.05


def _part_specs(oiio, path):
    """Specs of every part (subimage) of a file: multilayer EXRs put passes in parts."""
    image = oiio.ImageInput.open(str(path))
    specs, index = [], 0
    while image.seek_subimage(index, 0):
        specs.append(image.spec())
        index += 1
    image.close()
    return specs


# --- Saving and removing presets with the Add/Remove buttons (Blender's AddPresetBase).

@pytest.fixture
def user_render_presets(monkeypatch, tmp_path):
    """Blender's user preset folders moved into tmp_path (never the real user's config)."""
    monkeypatch.setenv("BLENDER_USER_SCRIPTS", str(tmp_path / "scripts"))
    return tmp_path / "scripts" / "presets" / "splatline" / "render"


def _ffmpeg(scene):
    f = scene.render.ffmpeg
    return (scene.render.image_settings.file_format, f.format, f.codec, f.ffmpeg_prores_profile,
            f.constant_rate_factor, f.ffmpeg_preset, scene.render.resolution_percentage)


@pytest.mark.parametrize("bundled, change", [
    ("prores_422", dict(ffmpeg_prores_profile="4444")),
    ("h264_mp4", dict(constant_rate_factor="PERC_LOSSLESS", ffmpeg_preset="BEST")),
])
def test_saved_video_preset_restores_its_codec_settings(bpy_empty, user_render_presets, bundled, change):
    bpy = bpy_empty
    scene = bpy.context.scene
    presets.apply_render_preset(bundled)
    for attr, value in change.items():
        setattr(scene.render.ffmpeg, attr, value)
    scene.render.resolution_percentage = 75
    saved = _ffmpeg(scene)
    assert bpy.ops.splatline.render_preset_add(name="My Video") == {"FINISHED"}
    path = user_render_presets / "My_Video.py"
    assert path.is_file() and presets.find_preset("My Video") == path
    presets.apply_render_preset("png_16bit")  # something else entirely
    ffmpeg = scene.render.ffmpeg
    ffmpeg.ffmpeg_prores_profile, ffmpeg.constant_rate_factor, ffmpeg.ffmpeg_preset = "422_PROXY", "LOW", "REALTIME"
    assert _ffmpeg(scene) != saved
    presets.apply_render_preset("My Video")
    assert _ffmpeg(scene) == saved


@pytest.mark.parametrize("bundled", sorted(EXPECT))
def test_every_bundled_preset_survives_save_and_load(bpy_empty, user_render_presets, bundled):
    bpy = bpy_empty
    scene = bpy.context.scene
    other = "png_16bit" if bundled != "png_16bit" else "prores_422"
    presets.apply_render_preset(other)
    presets.apply_render_preset(bundled)
    image = scene.render.image_settings
    saved = (_ffmpeg(scene), media_type(image), image.color_mode, image.color_depth)
    assert bpy.ops.splatline.render_preset_add(name=f"copy of {bundled}") == {"FINISHED"}
    presets.apply_render_preset(other)
    presets.apply_render_preset(f"copy of {bundled}")  # raises if the saved file fails to run
    assert (_ffmpeg(scene), media_type(image), image.color_mode, image.color_depth) == saved


def test_remove_saved_render_preset(bpy_empty, user_render_presets):
    bpy = bpy_empty
    presets.apply_render_preset("preview")
    for name in ("Keep Me", "Drop Me"):
        assert bpy.ops.splatline.render_preset_add(name=name) == {"FINISHED"}
    keep, drop = user_render_presets / "Keep_Me.py", user_render_presets / "Drop_Me.py"
    presets.apply_render_preset("Drop Me")  # the menu's active preset: what "-" removes
    assert bpy.ops.splatline.render_preset_add(remove_active=True) == {"FINISHED"}
    assert not drop.exists() and keep.is_file()
    assert "Drop_Me" not in presets.list_presets("render")
    assert bpy.ops.splatline.render_preset_add(name="Keep Me", remove_name=True) == {"FINISHED"}
    assert not keep.exists()


def test_removing_a_bundled_render_preset_says_why(bpy_empty, user_render_presets):
    bpy = bpy_empty
    presets.apply_render_preset("prores_422")
    with pytest.raises(RuntimeError, match="prores 422: a bundled output preset"):
        bpy.ops.splatline.render_preset_add(remove_active=True)
    assert presets.find_preset("prores_422").is_file()
    with pytest.raises(RuntimeError, match="no saved output preset"):
        bpy.ops.splatline.render_preset_add(name="Never Saved", remove_name=True)
