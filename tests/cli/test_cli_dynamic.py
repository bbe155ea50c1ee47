"""The command line with a dynamic (4D) capture: info and its alive fractions, convert between
dynamic formats and bake a moment or frames, one-line refusals, and a bare-capture render
that plays the capture's own time range."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from addon.__main__ import main
from addon.core import formats
from addon.core.dynamic import read_dynamic, write_dynamic
from testing.dynamic_scenes import spacetime_capture
from testing.paths import REPO


@pytest.fixture
def dancer(tmp_path):
    path = tmp_path / "dancer.ply"
    write_dynamic(path, spacetime_capture(1500))
    return path


def test_info_shows_the_model_range_and_alive_fractions(dancer, capsys):
    assert main(["info", str(dancer), "--json", "--stats"]) == 0
    info = json.loads(capsys.readouterr().out)
    capture = read_dynamic(dancer)
    assert (info["model"], info["count"], info["time_range"]) == ("spacetime", 1500, [0.0, 1.0])
    for name, t in (("start", 0.0), ("middle", 0.5), ("end", 1.0)):
        assert info["alive"][name] == pytest.approx(capture.alive_mask(t).mean())
    assert main(["info", str(dancer)]) == 0
    out = capsys.readouterr().out
    assert "spacetime" in out and "0 to 1" in out


def test_convert_to_splatv_and_back_keeps_every_moment(dancer, tmp_path, capsys):
    splatv, back = tmp_path / "d.splatv", tmp_path / "back.ply"
    assert main(["convert", str(dancer), str(splatv)]) == 0
    assert main(["convert", str(splatv), str(back)]) == 0
    a, b = read_dynamic(dancer), read_dynamic(back)
    for t in (0.0, 0.37, 1.0):
        fa, fb = a.at(t), b.at(t)
        common = np.intersect1d(fa.index, fb.index)
        assert common.size > 0.95 * fa.alive  # .splatv's half floats move a few across 1/255
        pa = fa.splats.positions[np.searchsorted(fa.index, common)]
        pb = fb.splats.positions[np.searchsorted(fb.index, common)]
        np.testing.assert_allclose(pb, pa, atol=0.05)  # half-float motion and rotation terms


def test_convert_bakes_a_moment_and_a_frame_range(dancer, tmp_path):
    capture = read_dynamic(dancer)
    assert main(["convert", str(dancer), str(tmp_path / "still.spz"), "--time", "0.5"]) == 0
    still = formats.read(tmp_path / "still.spz", axes="RDF")
    assert still.count == capture.at(0.5).alive
    (tmp_path / "seq").mkdir()
    assert main(["convert", str(dancer), str(tmp_path / "seq" / "d_###.ply"), "--frames", "1-3"]) == 0
    for frame in (1, 2, 3):  # 50 frames a segment, time 0 at frame 1
        baked = formats.read(tmp_path / "seq" / f"d_{frame:03d}.ply")
        np.testing.assert_array_equal(baked.positions, capture.at((frame - 1) / 50).splats.positions)


@pytest.mark.parametrize("args, message", [
    (["{out}/x.spz"], "bake one moment (--time T)"),
    (["{out}/x.ply", "--frames", "1-3"], "names each frame's file with #'s"),
])
def test_what_does_not_fit_is_one_line(dancer, tmp_path, args, message):
    args = [a.format(out=tmp_path) for a in args]
    done = subprocess.run([sys.executable, "-m", "addon", "convert", str(dancer), *args], cwd=REPO,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode != 0 and message in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1


def test_a_static_reader_refuses_a_dynamic_ply(dancer):
    with pytest.raises(formats.SplatFormatError, match="a dynamic .4D. capture"):
        formats.read(dancer)


def test_render_plays_the_captures_own_time_range(dancer, tmp_path):
    out = tmp_path / "frames"
    done = subprocess.run([sys.executable, "-m", "addon", "render", str(dancer), "--out", str(out),
                           "--resolution", "16x12", "--format", "PNG"], cwd=REPO,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert len(list(out.glob("frame_*.png"))) == 51  # a segment: 50 frames, both ends shown
