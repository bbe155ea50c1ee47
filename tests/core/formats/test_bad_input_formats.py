"""Bad input: every failure is a SplatFormatError naming the file and the reason, and no
array is sized from an unchecked header."""
from __future__ import annotations

import gzip
import os
import struct
import tracemalloc

import numpy as np
import pytest

from testing.spz_encode import blocks, encode
from addon.core.errors import SplatFormatError
from addon.core.formats import read, read_with_report, write
from addon.core.formats.ply import write_ply
from testing.synth import random_splats, write_ply_variant
from testing.reader_checks import fails


def ply_header(n, props=("x", "y", "z"), fmt="binary_little_endian", ptype="float"):
    lines = ["ply", f"format {fmt} 1.0", f"element vertex {n}"]
    lines += [f"property {ptype} {p}" for p in props] + ["end_header", ""]
    return "\n".join(lines).encode()


@pytest.fixture
def good_ply(tmp_path):
    path = tmp_path / "good.ply"
    write_ply(path, random_splats(20, 1, seed=9))
    return path


def test_truncated_ply(tmp_path, good_ply):
    data = good_ply.read_bytes()
    path = tmp_path / "cut.ply"
    path.write_bytes(data[:-7])
    fails(path, "truncated")
    path.write_bytes(data[:30])  # inside the header
    fails(path, "end_header")


def test_huge_vertex_count_rejected_before_allocating(tmp_path):
    """10^9 vertices claimed in a ~1 KB file: refused from the size check, and the peak
    traced allocation stays tiny (a 62-float record array would be ~248 GB)."""
    path = tmp_path / "huge.ply"
    path.write_bytes(ply_header(10 ** 9) + bytes(1000))
    tracemalloc.start()
    try:
        fails(path, "truncated", "1000000000")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2_000_000


def test_bad_ascii_bodies(tmp_path):
    path = tmp_path / "a.ply"
    write_ply_variant(path, random_splats(5, 0), "ascii")
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:-1]) + "\n")
    fails(path, "truncated", "4 of 5")
    path.write_text("\n".join(lines[:-1] + ["nan_or_not 1 2"]) + "\n")
    fails(path, "ascii")
    path.write_text("\n".join(lines[:-1] + [lines[-1] + " 9"]) + "\n")
    fails(path, "ascii")


def test_huge_ascii_count(tmp_path):
    path = tmp_path / "huge_ascii.ply"
    path.write_bytes(ply_header(10 ** 9, fmt="ascii") + b"1 2 3\n" * 10)
    fails(path, "truncated")


def test_missing_required_properties(tmp_path):
    path = tmp_path / "xyz.ply"
    path.write_bytes(ply_header(2) + bytes(24))
    msg = fails(path, "lacks", "opacity")
    assert "scale_0" in msg and "rot_0" in msg and "f_dc_0" in msg


def test_bad_rest_count_and_lists(tmp_path):
    props = ("x", "y", "z", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3",
             "opacity", "f_dc_0", "f_dc_1", "f_dc_2") + tuple(f"f_rest_{i}" for i in range(6))
    path = tmp_path / "rest.ply"
    path.write_bytes(ply_header(1, props) + bytes(4 * len(props)))
    fails(path, "f_rest", "degree")
    path.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 1\n"
                     b"property list uchar int vertex_indices\nend_header\n" + bytes(16))
    fails(path, "list")
    path.write_bytes(ply_header(1, ("x", "y", "x")) + bytes(12))
    fails(path, "repeats")


def test_empty_face_element_with_list_is_fine(tmp_path, good_ply):
    data = good_ply.read_bytes()
    head, body = data.split(b"end_header\n", 1)
    path = tmp_path / "face.ply"
    path.write_bytes(head + b"element face 0\nproperty list uchar int vertex_indices\nend_header\n" + body)
    assert read(path).count == 20


def test_not_a_ply(tmp_path):
    path = tmp_path / "fake.ply"
    path.write_bytes(b"hello world, not a ply at all")
    fails(path, "magic")
    path.write_bytes(b"ply\nformat binary_middle_endian 1.0\nend_header\n")
    fails(path, "format")


def test_empty_files(tmp_path):
    """A 0-byte file is an error in every format; a valid header with 0 splats is a valid,
    empty SplatSet."""
    for ext in (".ply", ".splat", ".spz"):
        path = tmp_path / f"zero{ext}"
        path.write_bytes(b"")
        fails(path, "empty")
    path = tmp_path / "none.ply"
    write_ply(path, random_splats(0, 2))
    s = read(path)
    assert s.count == 0 and s.sh_degree == 2
    spz = tmp_path / "none.spz"
    spz.write_bytes(encode(random_splats(0, 0), 4))
    assert read(spz).count == 0


def test_directory_and_missing_file(tmp_path):
    d = tmp_path / "dir.ply"
    d.mkdir()
    fails(d, "directory")
    fails(tmp_path / "absent.ply", "no such file")
    with pytest.raises(SplatFormatError, match="directory"):
        write(d, random_splats(3, 0))
    with pytest.raises(SplatFormatError, match="cannot write"):
        write(tmp_path / "no" / "such" / "dir.ply", random_splats(3, 0))
    with pytest.raises(SplatFormatError, match="cannot write"):
        write(tmp_path / "out.obj", random_splats(3, 0))  # .obj: a format with no splat writer


def test_unknown_extension(tmp_path):
    path = tmp_path / "mystery.bin"
    path.write_bytes(bytes(64))
    fails(path, "unknown")


def test_splat_truncated(tmp_path, testdata):
    path = tmp_path / "cut.splat"
    path.write_bytes((testdata / "test64.splat").read_bytes()[:-5])
    fails(path, "truncated")


def test_compressed_ply_inconsistent(tmp_path, testdata):
    data = (testdata / "test64.compressed.ply").read_bytes()
    path = tmp_path / "bad.compressed.ply"
    path.write_bytes(data.replace(b"element chunk 1", b"element chunk 2", 1))
    fails(path, "truncated")  # the extra chunk row is not in the file
    path.write_bytes(data.replace(b"packed_scale", b"packed_scalx", 1))
    fails(path, "packed_scale")
    path.write_bytes(data[:-100])
    fails(path, "truncated")


@pytest.fixture(scope="module")
def small():
    return random_splats(50, 1, seed=4)


def test_spz_wrong_magic_and_version(tmp_path, small):
    path = tmp_path / "bad.spz"
    path.write_bytes(encode(small, 3, magic=b"XXXX"))
    fails(path, "magic")
    raw = gzip.decompress(encode(small, 3))
    path.write_bytes(gzip.compress(raw[:4] + struct.pack("<I", 7) + raw[8:]))
    fails(path, "version 7")
    v4 = bytearray(encode(small, 4))
    v4[4] = 9
    path.write_bytes(bytes(v4))
    fails(path, "version 9")
    path.write_bytes(b"NOPE" + bytes(60))
    fails(path, "magic")


def test_spz_corrupt_streams(tmp_path, small):
    path = tmp_path / "corrupt.spz"
    gz = bytearray(encode(small, 3))
    gz[40:60] = bytes(20)
    path.write_bytes(bytes(gz))
    fails(path, "gzip")
    v4 = bytearray(encode(small, 4))
    v4[32 + 6 * 16 + 5] ^= 0xFF  # inside the first zstd stream's frame header
    path.write_bytes(bytes(v4))
    fails(path, "zstd")
    path.write_bytes(encode(small, 3)[:-20])
    fails(path)


def test_spz_oversized_streams(tmp_path, small):
    """A stream holding more than the header implies is refused while decompressing."""
    parts = blocks(small, 3)
    parts[-1] += bytes(10_000)
    path = tmp_path / "big.spz"
    path.write_bytes(encode(small, 3, parts=parts))
    fails(path, "larger")
    parts = blocks(small, 4)
    import zstandard
    honest = encode(small, 4)
    stream0 = zstandard.ZstdCompressor().compress(parts[0] + bytes(5000))
    toc0 = struct.pack("<QQ", len(stream0), len(parts[0]))
    old_len = struct.unpack_from("<Q", honest, 32)[0]
    body = honest[32 + 6 * 16 + old_len:]
    path.write_bytes(honest[:32] + toc0 + honest[48:32 + 6 * 16] + stream0 + body)
    fails(path, "larger")


def test_spz_huge_count(tmp_path, small):
    """10^9 splats claimed in a small spz: refused before any allocation from the count."""
    path = tmp_path / "huge.spz"
    path.write_bytes(encode(small, 3, count=10 ** 9))
    tracemalloc.start()
    try:
        fails(path, "1000000000")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2_000_000
    path.write_bytes(encode(small, 4, count=10 ** 9))
    fails(path, "1000000000")


@pytest.fixture
def bad_values_ply(tmp_path):
    s = random_splats(10, 1, seed=6)
    s.positions[1, 0] = np.nan
    s.scales[2, 1] = np.inf
    s.sh_rest[3, 2, 1] = -np.inf
    s.rotations[4] = 0.0
    path = tmp_path / "badvalues.ply"
    write_ply(path, s)
    return path, s


def test_nan_inf_zero_quaternion_fix(bad_values_ply):
    path, src = bad_values_ply
    s, report = read_with_report(path, bad="fix")
    assert (report.bad.nonfinite, report.bad.zero_quaternions) == (3, 1)
    assert report.bad.by_field["positions"] == 1 and report.bad.by_field["scales"] == 1
    assert s.count == 10
    assert np.isfinite(s.positions).all() and np.isfinite(s.scales).all() and np.isfinite(s.sh_rest).all()
    np.testing.assert_array_equal(s.opacities[[1, 2, 3]], 0.0)  # neutralised: invisible
    np.testing.assert_array_equal(s.rotations[4], [1, 0, 0, 0])  # INRIA draws zero as identity
    assert s.opacities[4] > 0 and s.opacities[0] > 0
    np.testing.assert_allclose(np.linalg.norm(s.rotations, axis=1), 1.0, atol=1e-6)


def test_nan_inf_zero_quaternion_drop_and_error(bad_values_ply):
    path, src = bad_values_ply
    s, report = read_with_report(path, bad="drop")
    assert s.count == 6 and report.bad.dropped == 4
    np.testing.assert_array_equal(s.positions, src.positions[[0, 5, 6, 7, 8, 9]])
    msg = fails(path, "nan/inf", "zero quaternion", bad="error")
    assert "3 splats" in msg


@pytest.mark.parametrize("suffix", [".ply", ".splat"])
def test_writers_report_a_full_disk(tmp_path, small, suffix):
    """/dev/full refuses every write with ENOSPC, as a disk that fills up does; the
    writer must say so, not leave a truncated file behind a success."""
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full on this system")
    target = tmp_path / f"full{suffix}"
    target.symlink_to("/dev/full")
    with pytest.raises(SplatFormatError, match="No space left") as err:
        write(target, small)
    assert str(target) in str(err.value)
