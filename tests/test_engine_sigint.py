"""Ctrl+C in a plain bpy script (the PyPI module, no command line): the job stops at the
frame in progress, every finished frame stays whole and the script gets control back."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

from engine_scene import guitar_scene, read_image

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

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
    # As from a terminal: SIGINT at its default. pytest-xdist workers ignore SIGINT, and
    # a child would inherit that; Python then leaves SIGINT ignored, and so does the engine.
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 60
        while not (out / "f_0001.png").exists():
            assert proc.poll() is None and time.monotonic() < deadline, "no first frame"
            time.sleep(0.02)
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 3, stdout + stderr
    assert "caught: Error: Splatline: render interrupted" in stdout
    frames = sorted(out.glob("*.png"))
    assert 1 <= len(frames) < 200
    for path in frames:
        assert read_image(path).shape == (32, 48, 4)
