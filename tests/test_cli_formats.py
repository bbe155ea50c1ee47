"""python -m addon info / convert, run as a user runs them (a real subprocess)."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from addon.core.formats import read
from addon.core.formats.ply import write_ply
from addon.core.formats.synth import random_splats
from conftest import ROOT

READABLE = ["guitar.ply", "guitar.compressed.ply", "guitar.splat", "guitar.spz", "guitar_v3.spz"]


def cli(*args):
    return subprocess.run([sys.executable, "-m", "addon", *map(str, args)], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("name", READABLE + ["test64.compressed.ply"])
def test_info_json(testdata, name):
    r = cli("info", testdata / name, "--json")
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    s = read(testdata / name)
    assert info["count"] == s.count and info["sh_degree"] == s.sh_degree
    assert info["format"] == ("compressed_ply" if "compressed" in name else name.split(".")[-1])
    assert info["axes"] == "RDF"
    np.testing.assert_array_equal(info["bbox_min"], s.positions.min(axis=0))
    np.testing.assert_array_equal(info["bbox_max"], s.positions.max(axis=0))
    assert info["bad_values"]["nonfinite"] == 0


def test_info_table(testdata):
    r = cli("info", testdata / "test64.spz")
    assert r.returncode == 0
    assert "64" in r.stdout and "SH degree" in r.stdout and "spz" in r.stdout


def test_info_reports_bad_values(tmp_path):
    s = random_splats(8, 0, seed=1)
    s.positions[2, 1] = np.nan
    s.rotations[5] = 0
    write_ply(tmp_path / "b.ply", s)
    info = json.loads(cli("info", tmp_path / "b.ply", "--json").stdout)
    assert info["bad_values"]["nonfinite"] == 1 and info["bad_values"]["zero_quaternions"] == 1
    assert all(np.isfinite(info["bbox_min"]))


@pytest.mark.parametrize("name", READABLE)
@pytest.mark.parametrize("out_ext", [".ply", ".splat"])
def test_convert_every_pair(testdata, tmp_path, name, out_ext):
    out = tmp_path / f"out{out_ext}"
    r = cli("convert", testdata / name, out)
    assert r.returncode == 0, r.stderr
    src, got = read(testdata / name), read(out)
    assert got.count == src.count == 90854
    if out_ext == ".ply":  # float PLY holds what was read: opacity within 1 ulp of 1.0
        np.testing.assert_array_equal(got.positions, src.positions)
        np.testing.assert_allclose(got.opacities, src.opacities, rtol=0, atol=np.finfo(np.float32).eps)
    else:  # .splat re-quantizes colour/alpha to u8 (rounded): half a step
        assert np.abs(got.opacities - src.opacities).max() <= 0.5 / 255 + 1e-7


def test_convert_options(testdata, tmp_path):
    out = tmp_path / "small.ply"
    r = cli("convert", testdata / "test64.ply", out, "--sh-degree", "1", "--min-opacity", "0.2",
            "--max-count", "10")
    assert r.returncode == 0, r.stderr
    s, src = read(out), read(testdata / "test64.ply")
    assert s.sh_degree == 1 and s.count == min(10, int((src.opacities >= 0.2).sum()))
    assert (s.opacities >= 0.2 - 1e-7).all()


@pytest.mark.parametrize("args,word", [
    (("info", "{tmp}/missing.ply"), "no such file"),
    (("info", "{tmp}"), "directory"),
    (("convert", "{data}/test64.ply", "{tmp}/x.spz"), "cannot write"),
    (("convert", "{tmp}/trunc.ply", "{tmp}/x.ply"), "truncated"),
])
def test_errors_are_one_line(testdata, tmp_path, args, word):
    (tmp_path / "trunc.ply").write_bytes((testdata / "test64.ply").read_bytes()[:-50])
    r = cli(*[a.format(tmp=tmp_path, data=testdata) for a in args])
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and word in lines[0] and "Traceback" not in r.stderr, r.stderr
