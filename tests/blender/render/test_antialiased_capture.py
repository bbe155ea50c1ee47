"""A capture trained with anti-aliasing (issue 42 item 6): its file's own mark (a PLY's
`SplatRenderMode: mip` comment, SPZ's flag 0x1) is read, kept on the object
(Object.splatline.antialiased, shown in the Look panel and overridable), rendered with
gsplat's opacity compensation, and written back on export."""
from __future__ import annotations

import dataclasses

import numpy as np

from addon.core import formats, reference
from addon.core.scene import RenderOptions
from testing.engine_scene import add_camera, read_exr_parts, set_output, setup_render
from testing.gl_scenes import psnr


def _capture(tmp_path):
    from testing.gl_scenes import random_splats

    s = random_splats(1500, 1, seed=7, spread=1.5)
    # log scale -3 (0.05) at 6 m over 96 px: about a pixel wide, where the compensation shows
    s.antialiased = True
    path = tmp_path / "aa.ply"
    formats.write(path, s)
    assert b"comment SplatRenderMode: mip\n" in path.read_bytes()[:400]
    return path


def test_flagged_capture_renders_as_the_reference_with_antialiased(bpy_empty, tmp_path):
    from addon.blender.data.files import import_file
    from addon.blender.evaluate.items import collect_items
    from addon.blender.render.camera import camera_from_blender
    from addon.core.colorspace import premultiplied_srgb_to_linear as to_scene_linear

    bpy = bpy_empty
    obj = import_file(bpy.context, _capture(tmp_path))
    assert obj.splatline.antialiased  # read from the file's comment
    scene = setup_render(bpy, 96, 64)
    assert not scene.splatline.render.antialiased  # the scene's own setting stays off
    add_camera(bpy, location=(0.0, -6.0, 0.5), target=(0.0, 0.0, 0.0))
    set_output(scene, "EXR", tmp_path / "still")
    bpy.ops.render.render(write_still=True)
    got = read_exr_parts(tmp_path / "still.exr")["ViewLayer.Combined"]
    depsgraph = bpy.context.evaluated_depsgraph_get()
    camera = camera_from_blender(scene, scene.camera, depsgraph)
    items = collect_items(depsgraph)
    want = to_scene_linear(reference.render(items, camera, RenderOptions(antialiased=True)).rgba)
    plain = to_scene_linear(reference.render(items, camera, RenderOptions(antialiased=False)).rgba)
    assert want[..., 3].max() > 0.2
    assert psnr(got, want) >= 60.0
    assert psnr(got, plain) < 45.0  # the compensation is really there, not a no-op

    obj.splatline.antialiased = False  # overridable: the plain render
    bpy.ops.render.render(write_still=True)
    got = read_exr_parts(tmp_path / "still.exr")["ViewLayer.Combined"]
    assert psnr(got, plain) >= 60.0


def test_export_writes_the_flag_back(bpy_empty, tmp_path):
    from addon.blender.data.files import export_object, import_file

    bpy = bpy_empty
    obj = import_file(bpy.context, _capture(tmp_path))
    for name in ("o.spz", "o.ply", "o.compressed.ply"):
        export_object(obj, tmp_path / name)
        assert formats.read(tmp_path / name).antialiased, name
    assert (tmp_path / "o.spz").read_bytes()[14] & 0x1
    obj.splatline.antialiased = False
    export_object(obj, tmp_path / "off.spz")
    assert not formats.read(tmp_path / "off.spz").antialiased
    back = import_file(bpy.context, tmp_path / "o.spz")
    assert back.splatline.antialiased


def test_panel_shows_the_flag(bpy_empty):
    from addon.blender.ui.object_panels import SPLATLINE_PT_look
    import inspect

    assert '"antialiased"' in inspect.getsource(SPLATLINE_PT_look.draw)
    prop = bpy_empty.types.Object.bl_rna.properties["splatline"].fixed_type.properties["antialiased"]
    assert prop.type == "BOOLEAN" and prop.default is False


def test_options_replace_keeps_other_fields():
    base = RenderOptions(key_bits=32)
    assert dataclasses.replace(base, antialiased=True).key_bits == 32


def test_handoff_to_blenders_engines_says_they_have_no_such_mode(native_bpy, tmp_path, capfd):
    """5.3: the import is a native splat object Blender's engines draw without the
    compensation: one line says so (and only for a flagged capture)."""
    from addon.blender.data.files import import_file

    import_file(native_bpy.context, _capture(tmp_path))
    lines = [line for line in capfd.readouterr().out.splitlines() if "anti-aliasing" in line]
    assert lines == ["aa: trained with anti-aliasing; Blender's own engines have no anti-aliased "
                     "splat mode (the Splatline engine renders it with the compensation)"]
    plain = tmp_path / "plain.ply"
    formats.write(plain, dataclasses.replace(formats.read(tmp_path / "aa.ply"), antialiased=False))
    import_file(native_bpy.context, plain)
    assert "anti-aliasing" not in capfd.readouterr().out
