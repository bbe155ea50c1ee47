"""SPZ decoding: the real v4 files re-encode to their own streams byte for byte, and
synthetic v1-v4 files decode within the format's steps."""
from __future__ import annotations

import struct

import numpy as np
import pytest

from testing.spz_encode import blocks, encode
from addon.core.errors import SplatFormatError
from addon.core.formats import read
from addon.core.formats.spz import _read_v4


@pytest.mark.parametrize("name", ["test64.spz", "guitar.spz"])
def test_real_v4_streams_reencode_exactly(testdata, name):
    """Decoding is the exact inverse of the writer's quantization: re-quantizing what we
    decoded gives the file's own bytes. Rotation rows where two components tie for largest
    within a step may legitimately pick the other one, so only clear rows are compared."""
    raw = (testdata / name).read_bytes()
    _, streams = _read_v4(name, raw)
    s = read(testdata / name)
    mine = blocks(s, 4)
    for i in (0, 1, 2, 3, 5):
        np.testing.assert_array_equal(np.frombuffer(mine[i], np.uint8), streams[i], err_msg=f"stream {i}")
    mag = np.sort(np.abs(s.rotations), axis=1)
    clear = mag[:, 3] - mag[:, 2] > 2 * np.sqrt(0.5) / 511
    assert clear.mean() > 0.95  # coverage guard: nearly every row is compared
    np.testing.assert_array_equal(np.frombuffer(mine[4], "<u4")[clear], streams[4].view("<u4")[clear])


@pytest.mark.parametrize("version", [1, 2, 3, 4])
def test_synthetic_versions(tmp_path, testdata, version):
    """Decode of each version against the (already quantized) test64 values: v1 positions
    are float16 (relative step 2^-10, half of it), v2+ fixed point is exact here because the
    source already sits on the 12-bit grid; v1/v2 rotations are three u8 of step 1/127.5 with
    w derived: within 3 half steps per component after renormalizing."""
    src = read(testdata / "test64.spz")
    path = tmp_path / f"v{version}.spz"
    path.write_bytes(encode(src, version))
    s = read(path)
    assert (s.count, s.sh_degree, s.axes) == (64, 3, "RUB")  # SPZ's documented frame
    if version == 1:
        bound = np.abs(src.positions) * 2.0 ** -11 + 2.0 ** -25
        assert (np.abs(s.positions - src.positions) <= bound).all()
    else:
        np.testing.assert_array_equal(s.positions, src.positions)
    np.testing.assert_array_equal(s.sh_rest, src.sh_rest)
    np.testing.assert_array_equal(s.sh_dc, src.sh_dc)
    np.testing.assert_array_equal(s.opacities, src.opacities)
    np.testing.assert_allclose(s.scales, src.scales, rtol=1e-6)
    sign = np.sign(np.einsum("ij,ij->i", s.rotations, src.rotations))[:, None]
    bound = 3 * 0.5 / 127.5 if version < 3 else 1e-6
    assert np.abs(s.rotations * sign - src.rotations).max() <= bound


def test_degree0_v4_has_five_streams(tmp_path, testdata):
    src = read(testdata / "test64.spz", sh_degree=0)
    path = tmp_path / "d0.spz"
    path.write_bytes(encode(src, 4))
    assert path.read_bytes()[15] == 5
    s = read(path)
    assert s.sh_degree == 0 and s.count == 64


def _with_extensions(raw: bytes, records: bytes, flags: int = 0x2) -> bytes:
    """A v4 file with extension records in its header zone (bytes 32..toc_offset), as
    Niantic's writer lays them out: the table of contents moves back by their length."""
    head = bytearray(raw[:32])
    head[14] |= flags
    toc = struct.unpack_from("<I", head, 16)[0]
    struct.pack_into("<I", head, 16, toc + len(records))
    return bytes(head) + records + raw[32:]


def _coordinate_record(value: int) -> bytes:
    return struct.pack("<III", 0xADBE0003, 4, value)


@pytest.mark.parametrize("value, axes", [(6, "RDF"), (4, "RUB"), (12, "RFU"), (0, "RUB")])
def test_v4_coordinate_system_extension_wins(tmp_path, testdata, value, axes):
    """Adobe's coordinate-system record names the stored frame (Niantic's enum: RUB 4, RDF 6,
    RFU 12; 0 unspecified: RUB); an unknown record before it is skipped by its length."""
    raw = (testdata / "test64.spz").read_bytes()
    path = tmp_path / "ext.spz"
    path.write_bytes(_with_extensions(raw, struct.pack("<II", 0x12340001, 3) + b"abc" + _coordinate_record(value)))
    s = read(path)
    assert s.axes == axes
    np.testing.assert_array_equal(s.positions, read(testdata / "test64.spz").positions)
    assert read(testdata / "test64.spz").axes == "RUB"  # no record: SPZ's documented frame


def test_v4_extension_frames_splatline_cannot_name_are_refused(tmp_path, testdata):
    raw = (testdata / "test64.spz").read_bytes()
    path = tmp_path / "luf.spz"
    path.write_bytes(_with_extensions(raw, _coordinate_record(7)))
    with pytest.raises(SplatFormatError, match="coordinate-system extension says LUF"):
        read(path)
    path.write_bytes(_with_extensions(raw, struct.pack("<II", 0xADBE0003, 400) + b"\0" * 4))
    with pytest.raises(SplatFormatError, match="runs past the header zone"):
        read(path)


def test_written_spz_is_rub_and_reads_back_in_the_sources_place(tmp_path, testdata):
    """Splatline writes RUB: an RDF source is turned (a half turn about x: y and z negate),
    and read back as RUB it stands where the source stood (reframed to RDF)."""
    from addon.core.formats import write
    from addon.core.reframe import reframe

    src = read(testdata / "test64.ply")
    path = tmp_path / "w.spz"
    write(path, src)
    raw = read(path)
    assert raw.axes == "RUB"
    step = 2.0 ** -13
    assert np.abs(raw.positions - src.positions * [1, -1, -1]).max() <= step
    assert np.abs(reframe(raw, "RDF").positions - src.positions).max() <= step


@pytest.mark.parametrize("version", [4, 3])
def test_antialiased_flag_reads_and_writes(tmp_path, testdata, version):
    """SPZ header flag 0x1 (Niantic: trained with anti-aliasing) <-> SplatSet.antialiased."""
    from dataclasses import replace

    from addon.core.formats import write

    src = read(testdata / "test64.ply")
    assert not read(testdata / "test64.spz").antialiased
    for flag in (True, False):
        path = tmp_path / f"{flag}.spz"
        write(path, replace(src, antialiased=flag), version=version)
        assert read(path).antialiased is flag
    raw = (testdata / "test64.spz").read_bytes()
    path.write_bytes(raw[:14] + bytes([raw[14] | 0x1]) + raw[15:])  # splat-transform's file, flagged
    assert read(path).antialiased


@pytest.mark.parametrize("comments, flag", [
    (["SplatRenderMode: mip"], True), (["  SPLATRENDERMODE:  MIP "], True), (["antialiased 1"], True),
    (["antialiased 0"], False), (["SplatRenderMode: default"], False), (["written by x"], False),
    (["antialiased 1", "SplatRenderMode: default"], False),  # the last one wins, as Brush reads
    (["SplatRenderMode: default", "antialiased 1"], True), (["SplatRenderMode: 2dgs"], False)])
def test_ply_comments_mark_antialiased_training(tmp_path, testdata, comments, flag):
    """Brush's `SplatRenderMode: mip` and Postshot's `antialiased 1`, as splat-transform reads them."""
    raw = (testdata / "test64.ply").read_bytes()
    head = b"".join(f"comment {c}\n".encode() for c in comments)
    cut = raw.index(b"element vertex")
    path = tmp_path / "c.ply"
    path.write_bytes(raw[:cut] + head + raw[cut:])
    assert read(path).antialiased is flag
