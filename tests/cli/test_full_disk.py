"""A frame is on disk whole or the render fails (cli/render_job.TemporaryFrames, core/whole_file):
`python -m addon render` on a small tmpfs that fills up mid-run stops at the first frame that
does not fit, with one line naming it and "no space left on device", exit 1; earlier frames
stay whole, and nothing under a final name is cut, nor an older frame replaced by a cut one.
(Blender's PNG writer closes a cut file and says "Saved:"; this used to exit 0.)"""
from __future__ import annotations

import os
import re
import subprocess
import sys

import pytest

from addon.core import whole_file
from testing.paths import REPO
from testing.png_check import png_whole
from testing.small_disk import leave_free, small_disk

FRAME_PNG = 200_000  # at least what one 960x540 PNG frame of the guitar takes (~220-250 kB)


def _render(capture, out, fmt, frames="1-6", size="960x540"):
    return subprocess.run([sys.executable, "-m", "addon", "render", str(capture), "--out", str(out),
                           "--frames", frames, "--resolution", size, "--format", fmt],
                          cwd=REPO, capture_output=True, text=True, timeout=300)


def _error_lines(stderr):
    return [line for line in stderr.splitlines() if line.startswith("error:")]


def _stopped_at(r, ext):
    """The frame the run says did not fit, checked against its one error line."""
    assert r.returncode == 1, r.stdout + r.stderr
    errors = _error_lines(r.stderr)
    assert len(errors) == 1, r.stderr
    m = re.search(rf"frame (\d+) not written to \S+frame_(\d+)\.{ext}: .*no space left on device", errors[0])
    assert m and int(m.group(1)) == int(m.group(2)), errors[0]
    return int(m.group(1))


@pytest.mark.parametrize("fmt, ext", [("PNG", "png"), ("EXR", "exr")])
def test_a_full_disk_stops_at_the_first_cut_frame_and_keeps_the_earlier_ones(tmp_path, testdata, fmt, ext):
    with small_disk(tmp_path / "disk") as disk:
        leave_free(disk, 2 * FRAME_PNG + FRAME_PNG // 2 if fmt == "PNG" else 700_000)
        out = os.path.join(disk, "out")
        r = _render(testdata / "guitar.splat", out, fmt)
        stopped = _stopped_at(r, ext)
        assert 1 <= stopped < 6
        names = sorted(os.listdir(out))
        assert names == [f"frame_{i:04d}.{ext}" for i in range(1, stopped)], names  # no temporaries
        for name in names:
            assert whole_file.problem(os.path.join(out, name)) is None, name
        if fmt == "PNG":
            assert all(png_whole(open(os.path.join(out, n), "rb").read()) for n in names)


def test_a_full_disk_never_replaces_a_good_frame_with_a_cut_one(tmp_path, testdata):
    with small_disk(tmp_path / "disk") as disk:
        out = os.path.join(disk, "out")
        r = _render(testdata / "guitar.splat", out, "PNG", frames="1-3")
        assert r.returncode == 0, r.stderr
        old = {n: open(os.path.join(out, n), "rb").read() for n in os.listdir(out)}
        leave_free(disk, 16_384)
        r = _render(testdata / "guitar.splat", out, "PNG", frames="1-3")
        assert _stopped_at(r, "png") == 1
        assert {n: open(os.path.join(out, n), "rb").read() for n in os.listdir(out)} == old


def test_a_movie_on_a_full_disk_fails_in_one_line_and_the_old_movie_survives(tmp_path, testdata):
    with small_disk(tmp_path / "disk") as disk:
        out = os.path.join(disk, "out")
        r = _render(testdata / "guitar.splat", out, "MP4", size="320x180")
        assert r.returncode == 0, r.stderr
        movie = os.path.join(out, "frame_0001-0006.mp4")
        old = open(movie, "rb").read()
        for free in (8192, 0):  # cut mid-movie; no room for its first bytes
            leave_free(disk, free)
            r = _render(testdata / "guitar.splat", out, "MP4", size="320x180")
            assert r.returncode == 1, r.stdout + r.stderr
            errors = _error_lines(r.stderr)
            assert len(errors) == 1 and "no space left on device" in errors[0].lower(), r.stderr
            assert out in errors[0], errors[0]  # the movie, or the folder where not a byte fits
            assert os.listdir(out) == ["frame_0001-0006.mp4"]
            assert open(movie, "rb").read() == old
            os.unlink(os.path.join(disk, "filler"))
