"""python -m addon info / convert with SOG and glTF, as a user runs them (a subprocess, so
OpenImageIO must be found without the test suite's sys.path help)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from addon.core.formats import detect_format, read
from testing.cli_runs import cli
from testing.webp_support import needs_straight_webp

FIELDS = ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")


@needs_straight_webp
@pytest.mark.parametrize("name,fmt", [("guitar.sog", "sog"), ("test64_sog_unbundled/meta.json", "sog"),
                                      ("guitar.glb", "glb")])
def test_info(testdata, name, fmt):
    r = cli("info", testdata / name, "--json")
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    s = read(testdata / name)
    assert (info["format"], info["count"], info["sh_degree"]) == (fmt, s.count, s.sh_degree)


@needs_straight_webp
@pytest.mark.parametrize("ext", [".glb", ".gltf"])
def test_convert_sog_to_gltf_keeps_every_value(testdata, tmp_path, ext):
    out = tmp_path / f"t{ext}"
    r = cli("convert", testdata / "test64.sog", out)
    assert r.returncode == 0, r.stderr
    src, back = read(testdata / "test64.sog"), read(out)
    for field in FIELDS:
        np.testing.assert_array_equal(getattr(back, field), getattr(src, field), err_msg=field)


def test_convert_to_compressed_ply_writes_one(testdata, tmp_path):
    out = tmp_path / "y.compressed.ply"
    r = cli("convert", testdata / "test64.ply", out)
    assert r.returncode == 0, r.stderr
    assert "compressed_ply" in r.stdout
    assert detect_format(out) == "compressed_ply"
    assert read(out).count == 64


def test_bad_sog_is_one_line(tmp_path):
    bad = tmp_path / "bad.sog"
    bad.write_bytes(b"PK\x03\x04 not really")
    r = cli("info", bad)
    assert r.returncode == 1
    assert r.stderr.strip().startswith(f"error: {bad}") and len(r.stderr.strip().splitlines()) == 1
