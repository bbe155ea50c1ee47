"""Frames of `python -m addon render` reach their final names only by a rename
(cli/render_job.TemporaryFrames), and a killed render leaves older frames untouched.

The child runs the CLI in-process with one more render_write handler, appended before
the job's own: at frame 2 it pauses right after Blender has written the file and before
the job renames it, and the test kills it there (kill -9 or SIGTERM)."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap

from testing.interrupt import wait_for_marker
from testing.png_check import png_whole
from testing.paths import REPO


ROOT = str(REPO)

CHILD = textwrap.dedent("""
    import os, sys, time
    sys.path.insert(0, {root!r})
    import bpy

    @bpy.app.handlers.persistent
    def pause_at_frame_2(scene, *_):
        if scene.frame_current == 2:
            with open({marker!r}, "w") as f:
                f.write("paused")
            for _ in range(2400):  # 120 s in slices (testing/interrupt.py says why)
                time.sleep(0.05)

    bpy.app.handlers.render_write.append(pause_at_frame_2)
    from addon.__main__ import main
    sys.exit(main(["render", {capture!r}, "--out", {out!r}, "--frames", "1-3",
                   "--resolution", "48x32", "--format", "PNG"]))
""")


def _old_frames(out):
    out.mkdir()
    old = {f"frame_000{i}.png": f"old frame {i}".encode() for i in (1, 2, 3)}
    for name, data in old.items():
        (out / name).write_bytes(data)
    return old


def _child(tmp_path, testdata, out):
    marker = tmp_path / "paused"
    code = CHILD.format(root=ROOT, marker=str(marker), capture=str(testdata / "guitar.splat"),
                        out=str(out))
    proc = subprocess.Popen([sys.executable, "-c", code], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    return proc, marker


def test_a_killed_render_leaves_the_frame_being_written_and_later_ones_untouched(tmp_path, testdata):
    out = tmp_path / "out"
    old = _old_frames(out)
    proc, marker = _child(tmp_path, testdata, out)
    wait_for_marker(proc, marker)
    proc.kill()
    proc.wait(60)
    assert png_whole((out / "frame_0001.png").read_bytes())  # finished: renamed in
    assert (out / "frame_0002.png").read_bytes() == old["frame_0002.png"]  # written, not yet renamed
    assert (out / "frame_0003.png").read_bytes() == old["frame_0003.png"]
    hidden = [n for n in os.listdir(out) if n.startswith(".") and not n.endswith(".lock")]
    assert len(hidden) == 1 and hidden[0].startswith(".frame_0002.") and hidden[0].endswith(".frametmp.png")

    # a normal run over it: whole frames, the dead run's temporary removed, none of its own left
    r = subprocess.run([sys.executable, "-m", "addon", "render", str(testdata / "guitar.splat"),
                        "--out", str(out), "--frames", "1-3", "--resolution", "48x32",
                        "--format", "PNG"], cwd=ROOT, capture_output=True, text=True, timeout=180)
    assert r.returncode == 0, r.stdout + r.stderr
    assert sorted(os.listdir(out)) == [f"frame_000{i}.png" for i in (1, 2, 3)]
    assert all(png_whole((out / f"frame_000{i}.png").read_bytes()) for i in (1, 2, 3))
    for i in (1, 2, 3):  # the progress lines name the final files
        assert f"frame {i} ({i}/3)" in r.stdout and str(out / f"frame_000{i}.png") in r.stdout
