"""Ctrl+C in a plain bpy script (the PyPI module, no command line): the job stops at the
frame in progress, every finished frame stays whole and the script gets control back."""
from __future__ import annotations

import sys
import textwrap

from testing.engine_scene import guitar_scene, read_image
from testing.interrupt import interrupt_after
from testing.paths import REPO

ROOT = str(REPO)

SCRIPT = textwrap.dedent("""
    import sys
    sys.path.insert(0, {root!r})
    import bpy
    from addon.cli import blender_session
    blender_session.start({blend!r})
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 200
    scene.render.filepath = {out!r}
    try:
        bpy.ops.render.render(animation=True)
    except RuntimeError as exc:
        print("caught:", str(exc).strip())
        sys.exit(3)
""")


def test_sigint_stops_a_bpy_script_render_between_frames(bpy_empty, testdata, tmp_path):
    bpy = bpy_empty
    scene, _, _ = guitar_scene(bpy, testdata, [1, 2, 3, 4], 48, 32, count=2000)
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGBA"
    blend = tmp_path / "g.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    out = tmp_path / "frames"
    script = tmp_path / "render.py"
    script.write_text(SCRIPT.format(root=ROOT, blend=str(blend), out=str(out / "f_####")))
    returncode, stdout, stderr = interrupt_after([sys.executable, str(script)], out / "f_0001.png")
    assert returncode == 3, stdout + stderr
    assert "caught: Error: Splatline: render interrupted" in stdout
    frames = sorted(out.glob("*.png"))
    assert 1 <= len(frames) < 200
    for path in frames:
        assert read_image(path).shape == (32, 48, 4)
