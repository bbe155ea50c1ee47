"""core/edit.py (the splat-transform actions) and the `convert` / `info` flags over it."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from addon.core import edit
from addon.core.formats import read
from addon.core.select import importance
from addon.core.sh import sh_basis
from testing.paths import REPO

ROOT = REPO


def _rot(q):
    w, x, y, z = q.astype(np.float64).T
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], 1)


def test_transform_moves_turns_and_grows_everything(testdata):
    src = read(testdata / "test64.ply")
    out = edit.transform(src, translate=(1, 2, 3), rotate=(0, 0, 90), scale=2.0)
    r = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])
    np.testing.assert_allclose(out.positions, 2 * src.positions @ r.T + [1, 2, 3], atol=1e-5)
    np.testing.assert_allclose(out.scales, 2 * src.scales, rtol=1e-6)
    np.testing.assert_allclose(_rot(out.rotations), r @ _rot(src.rotations), atol=1e-5)
    # the view-dependent colour turns with the splat: seen from R d it is what d saw before
    d = np.random.default_rng(0).normal(size=(32, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    before = np.einsum("dk,nkc->ndc", sh_basis(d, 3)[:, 1:], src.sh_rest)
    after = np.einsum("dk,nkc->ndc", sh_basis(d @ r.T, 3)[:, 1:], out.sh_rest)
    np.testing.assert_allclose(after, before, atol=1e-5)


def test_filters_keep_what_they_say(testdata):
    s = read(testdata / "guitar.ply")
    p = s.positions
    lo, hi = np.median(p, 0) - 0.2, np.median(p, 0) + 0.3
    assert edit.keep_box(s, lo, hi).count == int(((p >= lo) & (p <= hi)).all(1).sum()) > 0
    c = np.median(p, 0)
    inside = edit.keep_sphere(s, c, 0.5)
    assert inside.count == int((np.linalg.norm(p - c, axis=1) <= 0.5).sum()) > 0
    assert np.all(np.linalg.norm(inside.positions - c, axis=1) <= 0.5 + 1e-6)
    kept = edit.keep_where(s, "opacity >= 0.5")
    assert kept.count == int((s.opacities >= 0.5).sum()) and kept.opacities.min() >= 0.5
    assert edit.keep_where(s, "scale<0.01").scales.max(axis=1).max() < 0.01
    with pytest.raises(ValueError, match="unknown quantity"):
        edit.parse_test("alpha>1")
    with pytest.raises(ValueError, match="is not NAME"):
        edit.parse_test("opacity=1")


def test_decimate_keeps_the_most_important(testdata):
    s = read(testdata / "guitar.ply")
    n = edit.parse_count("10%", s.count)
    assert n == round(s.count / 10) and edit.parse_count("500", s.count) == 500
    d = edit.decimate(s, n)
    assert d.count == n and importance(d).min() >= np.sort(importance(s))[-n]
    for bad in ("ten", "-5", "150%"):
        with pytest.raises(ValueError):
            edit.parse_count(bad, s.count)


def test_merge_pads_sh_and_keeps_all(testdata):
    a, b = read(testdata / "test64.ply"), read(testdata / "guitar.ply")
    m = edit.merge([a, b])
    assert m.count == a.count + b.count and m.sh_degree == 3
    assert np.array_equal(m.sh_rest[:64], a.sh_rest) and not m.sh_rest[64:].any()
    assert np.array_equal(m.positions[64:], b.positions)


def test_statistics_per_column(testdata):
    s = read(testdata / "test64.ply")
    st = edit.statistics(s)
    assert st["opacity"]["max"] == pytest.approx(float(s.opacities.max()))
    assert st["x"]["mean"] == pytest.approx(float(s.positions[:, 0].mean()), rel=1e-6)
    assert all(v["nonfinite"] == 0 for v in st.values())


def cli(*args):
    return subprocess.run([sys.executable, "-m", "addon", *map(str, args)], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


def test_cli_merge_edit_and_stats(testdata, tmp_path):
    out = tmp_path / "m.spz"
    r = cli("convert", testdata / "test64.ply", testdata / "guitar.spz", out,
            "--translate", 0, 0, 1, "--keep-where", "opacity>0.1", "--decimate", "50%", "--spz-version", 3)
    assert r.returncode == 0, r.stderr
    back = read(out)
    merged = edit.keep_where(edit.merge([read(testdata / "test64.ply"), read(testdata / "guitar.spz")]), "opacity>0.1")
    assert back.count == round(merged.count / 2) and back.sh_degree == 3
    info = json.loads(cli("info", out, "--json", "--stats").stdout)
    assert info["stats"]["opacity"]["min"] > 0.1 - 0.5 / 255


@pytest.mark.parametrize("flags,message", [
    (["--keep-where", "opac>1"], "unknown quantity 'opac'"),
    (["--decimate", "lots"], "is not a count"),
    (["--scale", "0"], "--scale must be a positive number"),
    (["--keep-sphere", "0", "0", "0", "-1"], "radius must be >= 0"),
])
def test_cli_bad_flags_one_line(testdata, tmp_path, flags, message):
    r = cli("convert", testdata / "test64.ply", tmp_path / "o.ply", *flags)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and message in r.stderr  # usage
    assert not (tmp_path / "o.ply").exists()
