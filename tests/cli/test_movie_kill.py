"""A killed movie render never touches the previous movie (cli/render_job.TemporaryFrames): the
movie is written under a hidden temporary name and renamed once closed. kill -9 leaves that
temporary (the next render removes it); SIGTERM ends the movie at the frames that finished and
names it for them (frame_0001-0003.mp4), saying so. (It used to turn the earlier 6-frame movie
into a 48-byte file on kill -9, and leave 5 frames named frame_0001-0006.mp4 on SIGTERM.)

The child runs the CLI in-process with one more render_write handler, appended before the
job's own: at frame 3 it pauses right after Blender has appended the frame, until stopped."""
from __future__ import annotations

import os
import signal
import struct
import subprocess
import sys
import textwrap

from addon.core import whole_file
from testing.interrupt import wait_for_marker
from testing.paths import REPO

CHILD = textwrap.dedent("""
    import os, sys, time
    sys.path.insert(0, {root!r})
    import bpy
    from addon.core import stop

    @bpy.app.handlers.persistent
    def pause_at_frame_3(scene, *_):
        if scene.frame_current == 3:
            with open({marker!r}, "w") as f:
                f.write("paused")
            for _ in range(2400):  # 120 s in slices (testing/interrupt.py says why)
                if stop.stop_requested():
                    break
                time.sleep(0.05)

    bpy.app.handlers.render_write.append(pause_at_frame_3)
    from addon.__main__ import main
    rc = main({argv!r})
    # bpy 4.5 hangs at exit in a C++ destructor while a Python handler is still registered
    while pause_at_frame_3 in bpy.app.handlers.render_write:
        bpy.app.handlers.render_write.remove(pause_at_frame_3)
    sys.exit(rc)
""")


def _argv(capture, out):
    return ["render", str(capture), "--out", str(out), "--frames", "1-6", "--resolution", "160x96",
            "--format", "MP4"]


def _frames_in(path) -> int:
    """The sample count of the movie's video track (its stsz box)."""
    data = open(path, "rb").read()
    at = data.index(b"stsz")
    return struct.unpack(">I", data[at + 12:at + 16])[0]


def _old_movie(tmp_path, capture):
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "addon", *_argv(capture, out)], cwd=REPO,
                       capture_output=True, text=True, timeout=180)
    assert r.returncode == 0, r.stdout + r.stderr
    movie = out / "frame_0001-0006.mp4"
    assert f"wrote {movie}" in r.stdout and _frames_in(movie) == 6
    return out, movie, movie.read_bytes()


def _paused_child(tmp_path, capture, out):
    marker = tmp_path / "paused"
    code = CHILD.format(root=str(REPO), marker=str(marker), argv=_argv(capture, out))
    proc = subprocess.Popen([sys.executable, "-c", code], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    wait_for_marker(proc, marker)
    return proc


def test_kill_9_mid_movie_leaves_the_previous_movie_whole(tmp_path, testdata):
    out, movie, old = _old_movie(tmp_path, testdata / "guitar.splat")
    proc = _paused_child(tmp_path, testdata / "guitar.splat", out)
    proc.kill()
    proc.wait(60)
    assert movie.read_bytes() == old
    hidden = [n for n in os.listdir(out) if n.startswith(".") and not n.endswith(".lock")]
    assert len(hidden) == 1 and hidden[0].endswith(".frametmp.mp4"), hidden

    # the next run removes the dead run's temporary and replaces the movie whole
    r = subprocess.run([sys.executable, "-m", "addon", *_argv(testdata / "guitar.splat", out)],
                       cwd=REPO, capture_output=True, text=True, timeout=180)
    assert r.returncode == 0, r.stdout + r.stderr
    assert os.listdir(out) == ["frame_0001-0006.mp4"]
    assert whole_file.problem(str(movie)) is None and _frames_in(movie) == 6


def test_sigterm_mid_movie_names_the_frames_it_holds_and_keeps_the_previous_movie(tmp_path, testdata):
    out, movie, old = _old_movie(tmp_path, testdata / "guitar.splat")
    proc = _paused_child(tmp_path, testdata / "guitar.splat", out)
    proc.send_signal(signal.SIGTERM)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stdout + stderr
    held = out / "frame_0001-0003.mp4"
    assert f"interrupted: wrote {held}" in stdout, stdout + stderr
    assert sorted(os.listdir(out)) == ["frame_0001-0003.mp4", "frame_0001-0006.mp4"]
    assert movie.read_bytes() == old
    assert whole_file.problem(str(held)) is None and _frames_in(held) == 3
