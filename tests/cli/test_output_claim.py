"""An output is claimed while it is written (core/atomic.claim): a second `render` into the
same --out folder, or a second `convert` to the same output, stops with one line and exit 1
while the first goes on whole; SIGTERM stops a render as Ctrl+C does."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

from testing.interrupt import wait_for_marker
from testing.png_check import png_whole
from testing.paths import REPO

ROOT = str(REPO)

RENDER_CHILD = textwrap.dedent("""
    import os, sys, time
    sys.path.insert(0, {root!r})
    import bpy

    @bpy.app.handlers.persistent
    def hold_frame_2(scene, *_):  # Blender has written frame 2; hold until told to go on
        if scene.frame_current == 2:
            open({marker!r}, "w").close()
            t0 = time.monotonic()
            while not os.path.exists({go!r}) and time.monotonic() - t0 < 120:
                time.sleep(0.02)

    bpy.app.handlers.render_write.append(hold_frame_2)
    from addon.__main__ import main
    rc = main(["render", {capture!r}, "--out", {out!r}, "--frames", "1-3",
               "--resolution", "48x32", "--format", "PNG"])
    # bpy 4.5 hangs at exit in a C++ destructor while a Python handler is still registered
    bpy.app.handlers.render_write.remove(hold_frame_2)
    sys.exit(rc)
""")

CONVERT_CHILD = textwrap.dedent("""
    import os, sys, time
    sys.path.insert(0, {root!r})
    real_replace = os.replace

    def held_replace(src, dst, *a, **k):  # every byte written, before the rename
        open({marker!r}, "w").close()
        t0 = time.monotonic()
        while not os.path.exists({go!r}) and time.monotonic() - t0 < 120:
            time.sleep(0.02)
        return real_replace(src, dst, *a, **k)

    os.replace = held_replace
    from addon.__main__ import main
    sys.exit(main(["convert", {source!r}, {out!r}]))
""")


def _start(code):
    return subprocess.Popen([sys.executable, "-c", code], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _render_child(tmp_path, testdata, out):
    marker, go = tmp_path / "held", tmp_path / "go"
    proc = _start(RENDER_CHILD.format(root=ROOT, marker=str(marker), go=str(go), out=str(out),
                                      capture=str(testdata / "guitar.splat")))
    wait_for_marker(proc, marker)
    return proc, go


def _one_error_line(stderr: str) -> str:
    errors = [line for line in stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, stderr
    assert "Traceback" not in stderr, stderr
    return errors[0]


def _while_held(first, go, *args):
    """A second CLI run while `first` holds its claim, then `first` let go (the go file).
    Returns the second's CompletedProcess and the first's (exit code, stdout, stderr)."""
    try:
        second = subprocess.run([sys.executable, "-m", "addon", *map(str, args)], cwd=ROOT,
                                capture_output=True, text=True, timeout=180)
    finally:
        go.touch()
    rc_first = first.wait(180)
    return second, (rc_first, *first.communicate())


def test_a_second_render_into_the_same_folder_stops_with_one_line(tmp_path, testdata):
    out = tmp_path / "out"
    first, go = _render_child(tmp_path, testdata, out)
    second, (rc_first, stdout, stderr) = _while_held(
        first, go, "render", testdata / "guitar.splat", "--out", out, "--frames", "1-3",
        "--resolution", "48x32", "--format", "PNG")
    assert second.returncode == 1, second.stdout + second.stderr
    line = _one_error_line(second.stderr)
    assert str(out) in line and "another Splatline run" in line and f"process {first.pid}" in line
    assert "frame 1 (" not in second.stdout  # it rendered nothing
    assert rc_first == 0, stdout + stderr
    assert sorted(os.listdir(out)) == [f"frame_000{i}.png" for i in (1, 2, 3)]
    assert all(png_whole((out / f"frame_000{i}.png").read_bytes()) for i in (1, 2, 3))


def test_a_second_convert_to_the_same_output_stops_with_one_line(tmp_path, testdata):
    out = tmp_path / "out"
    out.mkdir()
    marker, go = tmp_path / "held", tmp_path / "go"
    first = _start(CONVERT_CHILD.format(root=ROOT, marker=str(marker), go=str(go),
                                        source=str(testdata / "guitar.splat"), out=str(out / "g.ply")))
    wait_for_marker(first, marker)
    second, (rc_first, stdout, stderr) = _while_held(first, go, "convert", testdata / "guitar.spz",
                                                     out / "g.ply")
    assert second.returncode == 1, second.stdout + second.stderr
    line = _one_error_line(second.stderr)
    assert str(out / "g.ply") in line and "another Splatline run" in line
    assert rc_first == 0, stdout + stderr
    assert sorted(os.listdir(out)) == ["g.ply"]
    from addon.core.formats import read
    assert read(str(out / "g.ply")).count == read(str(testdata / "guitar.splat")).count


def test_sigterm_stops_a_render_as_ctrl_c_does(tmp_path, testdata):
    out = tmp_path / "out"
    proc, go = _render_child(tmp_path, testdata, out)
    proc.send_signal(signal.SIGTERM)  # while frame 2 is written and not yet renamed
    time.sleep(0.3)
    go.touch()
    stdout, stderr = proc.communicate(timeout=180)
    assert proc.returncode == 130, (proc.returncode, stdout[-1500:], stderr[-1500:])
    assert "interrupted: 2 finished frame(s) kept" in stdout
    assert sorted(os.listdir(out)) == ["frame_0001.png", "frame_0002.png"]  # no temporary, no lock
    assert all(png_whole((out / f"frame_000{i}.png").read_bytes()) for i in (1, 2))
