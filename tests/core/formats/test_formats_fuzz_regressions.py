"""What fuzzing the readers found (test_formats_fuzz.py): one test per defect, each of which failed
on the code before its fix (see the commit messages)."""
from __future__ import annotations

import os
import resource
import shutil
import signal
import subprocess
import sys
import tracemalloc

import numpy as np
import pytest

from testing.spz_encode import encode
from addon.core import budget
from addon.core.errors import SplatFormatError
from addon.core.formats import read, read_with_report, write
from addon.core.formats.ply import write_ply
from addon.core.formats.splat import RECORD
from testing.synth import random_splats
from addon.core.splats import SplatSet
from testing.reader_checks import fails
from testing.webp_support import STRAIGHT_WEBP
from testing.paths import REPO

ROOT = str(REPO)



def _ply_with_rotations(tmp_path, rotations) -> str:
    s = random_splats(len(rotations), 0, seed=3)
    s.rotations[:] = np.asarray(rotations, np.float32)
    path = tmp_path / "rot.ply"
    write_ply(path, s)
    return path


def _unit(q, tol=1e-6) -> bool:
    return bool(np.isfinite(q).all() and (np.abs(np.linalg.norm(q.astype(np.float64), axis=1) - 1) < tol).all())


def test_b1_fix_never_outputs_nan_inf_or_zero_quaternions(tmp_path):
    """The float32 norm under/overflowed: (1e-30, 1e-30, 1e-30, NaN) became (inf, inf, inf,
    nan) and (3e38, 3e38, 0, NaN) became all zeros, after the default bad="fix"."""
    path = _ply_with_rotations(tmp_path, [(1e-30, 1e-30, 1e-30, np.nan), (3e38, 3e38, 0, np.nan),
                                          (1, 0, 0, 0)])
    s, report = read_with_report(path)
    assert report.bad.nonfinite == 2
    assert _unit(s.rotations), s.rotations
    np.testing.assert_allclose(s.rotations[1], [np.sqrt(0.5), np.sqrt(0.5), 0, 0], rtol=1e-6)


def test_b1_huge_and_tiny_finite_quaternions_normalise(tmp_path):
    path = _ply_with_rotations(tmp_path, [(3e38, 3e38, 3e38, 3e38), (1e-30, 1e-30, 1e-30, 1e-30)])
    s = read(path)
    np.testing.assert_allclose(s.rotations, 0.5, rtol=1e-6)


def test_b2_tiny_nonzero_quaternion_is_normalised(tmp_path):
    """(1e-23, 0, 0, 0): its float32 squared norm is 0, so it was neither normalised nor
    counted as a zero quaternion; it stayed at length 1e-23."""
    path = _ply_with_rotations(tmp_path, [(1e-23, 0, 0, 0), (0, -1e-40, 0, 0)])
    s, report = read_with_report(path)
    np.testing.assert_array_equal(s.rotations, [[1, 0, 0, 0], [0, -1, 0, 0]])
    assert report.bad.total == 0


def test_b3_compressed_ply_normalises(tmp_path, testdata):
    """packed_rotation 0xFFFFFFFF: three stored components of 0.707 and a largest of 0
    gave |q| = 1.22."""
    data = bytearray((testdata / "test64.compressed.ply").read_bytes())
    body = data.index(b"end_header\n") + len(b"end_header\n")
    chunk_bytes = 18 * 4  # 12 bounds + 6 colour bounds, float32, one chunk
    first_vertex = body + chunk_bytes
    data[first_vertex + 4:first_vertex + 8] = b"\xff\xff\xff\xff"  # packed_rotation of splat 0
    path = tmp_path / "rot.compressed.ply"
    path.write_bytes(bytes(data))
    s = read(path)
    assert _unit(s.rotations), np.linalg.norm(s.rotations, axis=1)[:3]


def _splat_with_negative_scale(tmp_path, testdata):
    rec = np.fromfile(testdata / "test64.splat", RECORD)
    rec["scale"][5, 1] = -0.02
    rec["scale"][9, 0] = 0.0
    path = tmp_path / "neg.splat"
    rec.tofile(path)
    return path


def test_b4_splat_negative_scales_are_reported(tmp_path, testdata):
    path = _splat_with_negative_scale(tmp_path, testdata)
    s, report = read_with_report(path)  # fix: |scale| draws the same (the covariance uses S^2)
    assert report.bad.nonpositive_scales == 2 and "scale" in report.bad.summary()
    assert (s.scales > 0).all() and np.isfinite(s.scales).all()
    assert s.scales[5, 1] == np.float32(0.02)
    s, report = read_with_report(path, bad="drop")
    assert s.count == 62
    fails(path, "scale", bad="error")


def test_b4_convert_negative_scale_writes_no_nan(tmp_path, testdata):
    src = _splat_with_negative_scale(tmp_path, testdata)
    out = tmp_path / "out.ply"
    proc = subprocess.run([sys.executable, "-m", "addon", "convert", str(src), str(out), "--bad-values", "fix"],
                          cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert "RuntimeWarning" not in proc.stderr and "scale" in proc.stderr, proc.stderr
    s = read(out)
    assert np.isfinite(s.scales).all() and (s.scales > 0).all()


def test_b4_writer_refuses_negative_scales(tmp_path):
    s = random_splats(4, 0, seed=1)
    s.scales[2, 0] = -1.0
    with pytest.raises(SplatFormatError, match="scale"):
        write(tmp_path / "neg.ply", s)


def _limit_file_size(limit):
    def apply():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # then write() fails with EFBIG
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


def test_b5_failed_write_leaves_the_input_intact(tmp_path, testdata):
    """`convert x.ply x.ply` under a file-size limit: the write fails part way; the input
    (the same file) must be untouched and no temporary file left beside it."""
    path = tmp_path / "x.ply"
    shutil.copyfile(testdata / "test64.ply", path)
    before = path.read_bytes()
    proc = subprocess.run([sys.executable, "-B", "-m", "addon", "convert", str(path), str(path)],
                          cwd=ROOT, capture_output=True, text=True,
                          preexec_fn=_limit_file_size(len(before) // 2))
    assert proc.returncode == 1, proc.stderr
    assert str(path) in proc.stderr and "too large" in proc.stderr.lower(), proc.stderr
    assert path.read_bytes() == before
    assert os.listdir(tmp_path) == ["x.ply"]


def test_b5_write_replaces_atomically_and_keeps_mode(tmp_path):
    s = random_splats(10, 1, seed=2)
    path = tmp_path / "out.ply"
    path.write_bytes(b"old")
    os.chmod(path, 0o640)
    write(path, s)
    assert os.stat(path).st_mode & 0o777 == 0o640
    np.testing.assert_array_equal(read(path).positions, s.positions)
    assert os.listdir(tmp_path) == ["out.ply"]


def test_b6_huge_header_names_the_limit(tmp_path):
    lines = ["ply", "format binary_little_endian 1.0", "element vertex 1"]
    lines += [f"property float p{i}" for i in range(100_000)] + ["end_header", ""]
    path = tmp_path / "wide.ply"
    path.write_bytes("\n".join(lines).encode() + bytes(400_000))
    msg = fails(path, "1 mib")
    assert "header" in msg


def _bomb(tmp_path, n=20_000_000):
    """A legal v4 spz whose streams expand to n degree-0 splats: a few KB on disk."""
    parts = [bytes(size * n) for size in (9, 1, 3, 3, 4)]  # zeros: all decode to valid splats
    path = tmp_path / "bomb.spz"
    path.write_bytes(encode(SplatSet.allocate(1, 0), 4, count=n, parts=parts))
    return path


@pytest.fixture(scope="module")
def bomb(tmp_path_factory):
    return _bomb(tmp_path_factory.mktemp("bomb"))


def test_splat_budget_refuses_before_decompressing(bomb):
    assert os.path.getsize(bomb) < 100_000
    tracemalloc.start()
    try:
        msg = fails(bomb, "20000000", "1000", max_splats=1000)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert "max_splats" in msg or "budget" in msg
    assert peak < 2_000_000


def test_splat_budget_defaults_to_available_memory(bomb, monkeypatch):
    monkeypatch.setattr(budget, "available_memory", lambda: 1 << 30)
    msg = fails(bomb, "20000000", "memory")
    assert "budget" in msg


def test_splat_budget_applies_to_every_format(tmp_path, testdata):
    sog = ("test64.sog", "test64_sog_unbundled/meta.json") if STRAIGHT_WEBP else ()
    for name in ("test64.ply", "test64.compressed.ply", "test64.splat", "test64.spz", "test64.glb", *sog):
        fails(testdata / name, "64", "budget", max_splats=63)
        assert read(testdata / name, max_splats=64).count == 64


def test_cli_max_splats(bomb):
    proc = subprocess.run([sys.executable, "-m", "addon", "info", str(bomb), "--max-splats", "500"],
                          cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 1 and "budget" in proc.stderr and str(bomb) in proc.stderr, proc.stderr
    proc = subprocess.run([sys.executable, "-m", "addon", "convert", "--help"], cwd=ROOT,
                          capture_output=True, text=True)
    assert "--max-splats" in proc.stdout
