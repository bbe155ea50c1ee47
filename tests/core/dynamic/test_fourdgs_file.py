""".4dgs files: Splatline's reader (core/dynamic/fourdgs.py) and writer (fourdgs_write.py)
against the format's reference implementation, the PyPI package fourdgs 0.6.0 (imported;
the tests skip without it). Both directions: files fourdgs writes, with its common options,
read by Splatline; files Splatline writes read by fourdgs.read (and passed by its
validator). In each, Splatline's capture.at(t) equals fourdgs' gaussians.state_at(t) on the
same file, splat for splat (both keep the file's order), at window edges and time centres.
Hostile files are refused in one line naming the file."""
from __future__ import annotations

import struct
import zlib
from dataclasses import replace

import numpy as np
import pytest

from addon.core.dynamic import read_dynamic, to_fourdgs, write_dynamic
from addon.core.dynamic import fourdgs_wire as wire
from addon.core.dynamic.fourdgs import read_fourdgs
from addon.core.dynamic.fourdgs_write import write_fourdgs
from addon.core.errors import SplatFormatError
from testing.dynamic_captures import LINEAR, raw_spacetime, same_rotation, write_raw_ply
from testing.dynamic_checks import fourdgs_state_matches

fourdgs = pytest.importorskip("fourdgs", reason="the fourdgs peer (pip install fourdgs==0.6.0) is absent")
from fourdgs.validate import validate  # noqa: E402  (after the skip)


def _gaussians(n=3000, seed=40, sh_degree=3, object_ids=False):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    sigma = rng.uniform(0.05, 1.0, n)
    sigma[::7] = np.inf  # never fades
    i = np.arange(n)
    lo = np.where(i % 5 == 0, rng.uniform(0, 1, n), -np.inf)
    hi = np.where(i % 3 == 0, np.where(np.isinf(lo), rng.uniform(1, 3, n), lo + rng.uniform(0.5, 2.0, n)), np.inf)
    coeffs = {0: 0, 1: 3, 2: 8, 3: 15}[sh_degree]
    return fourdgs.GaussianSet(
        positions=rng.normal(0, 1, (n, 3)).astype(np.float32), scales=rng.uniform(0.01, 0.1, (n, 3)).astype(np.float32),
        rotations=(q / np.linalg.norm(q, axis=1, keepdims=True)).astype(np.float32),
        colors=rng.uniform(0, 1, (n, 4)).astype(np.float32), motions=rng.normal(0, 0.5, (n, 3)).astype(np.float32),
        mu_t=rng.uniform(0, 3, n).astype(np.float32), sigma_t=sigma.astype(np.float32),
        win_lo=lo.astype(np.float32), win_hi=hi.astype(np.float32),
        sh=rng.integers(0, 256, (n, 3 * coeffs)).astype(np.uint8) if coeffs else None, sh_degree=sh_degree,
        object_id=rng.integers(0, 5, n).astype(np.uint32) if object_ids else None)


def _times(capture, scene):
    """0, the end, time centres, and window edges (lo, just before hi, hi) of a few splats."""
    d = scene.gaussians
    finite_lo = np.flatnonzero(np.isfinite(d.win_lo))[:3]
    finite_hi = np.flatnonzero(np.isfinite(d.win_hi))[:3]
    edges = [float(d.win_lo[i]) for i in finite_lo] + [float(d.win_hi[i]) for i in finite_hi]
    edges += [float(np.nextafter(d.win_hi[i], -np.inf)) for i in finite_hi]
    return [0.0, scene.duration_sec, *map(float, d.mu_t[:4]), *edges, 1.234]


def _same_file(capture, scene) -> None:
    """Splatline's decode of a file equals fourdgs' decode of it, array by array, and at(t)
    equals state_at(t) at every test time."""
    d = scene.gaussians
    assert capture.count == d.count and (capture.t_start, capture.t_end) == (0.0, scene.duration_sec)
    assert capture.cutoff == scene.header.cutoff and capture.unit == "seconds"
    np.testing.assert_array_equal(capture.positions, d.positions)
    np.testing.assert_array_equal(capture.scales, d.scales)
    np.testing.assert_array_equal(capture.t_center, d.mu_t)
    np.testing.assert_array_equal(capture.t_scale, d.sigma_t)
    np.testing.assert_array_equal(capture.opacities, d.colors[:, 3])
    np.testing.assert_array_equal(capture.window, np.stack([d.win_lo, d.win_hi], 1))
    finite = np.isfinite(d.motions).all(axis=1)  # fourdgs makes NaN velocities for splats never valid
    np.testing.assert_array_equal(capture.motion[finite, 0], d.motions[finite])
    assert same_rotation(capture.rotations.astype(np.float64), d.rotations[:, [3, 0, 1, 2]]).max() <= 1e-6
    np.testing.assert_allclose(0.5 + 0.28209479177387814 * capture.sh_dc, d.colors[:, :3], atol=1e-6)
    if d.sh is not None:
        k = capture.sh_rest.shape[1]
        mine = capture.sh_rest.transpose(0, 2, 1).reshape(d.count, 3 * k)
        np.testing.assert_allclose(mine, -4.0 + d.sh.astype(np.float64) * 8.0 / 255.0, atol=1e-6)
    else:
        assert capture.sh_rest.shape[1] == 0
    alive = 0
    for t in _times(capture, scene):
        alive += fourdgs_state_matches(capture, d.state_at(t, scene.header.cutoff), t)
    assert alive > 0


OPTIONS = {
    "default": {},
    "zstd": {"codec": 1, "level": 3},
    "one chunk per window": {"max_depth": 0},
    "many chunks": {"min_chunk_gaussians": 64},
    "no index": {"write_index": False},
    "no crc": {"write_crc": False},
    "fine": {"profile": "fine"},
    "coarse": {"profile": "coarse"},
    "cutoff 0.2": {"cutoff": 0.2},
    "sh band 1 only": {"sh_bands": 1},
    "sh bit depths": {"sh_bit_depths": "aggressive"},
    "statistics and summary offsets": {"write_statistics": True, "write_summary_offsets": True},
    "source ids": {"preserve_source_ids": True},
}


@pytest.mark.parametrize("name", list(OPTIONS))
def test_fourdgs_written_files_read_by_splatline(tmp_path, name):
    path = tmp_path / "theirs.4dgs"
    fourdgs.write(path, _gaussians(), 3.0, options=fourdgs.WriteOptions(**OPTIONS[name]))
    _same_file(read_dynamic(path), fourdgs.read(str(path), recover_truncated=False))


@pytest.mark.parametrize("degree", [0, 2])
def test_fourdgs_sh_degrees_and_object_ids(tmp_path, degree):
    path = tmp_path / "theirs.4dgs"
    fourdgs.write(path, _gaussians(1200, seed=41, sh_degree=degree, object_ids=True), 2.5)
    capture = read_dynamic(path)
    assert capture.sh_degree == degree
    _same_file(capture, fourdgs.read(str(path), recover_truncated=False))


def _compress_chunks(data: bytes, codec: str) -> bytes:
    """A file whose Chunk records compress their whole streams block (the chunk-level codec
    fourdgs reads but does not write); built from one with no index, so no offset moves."""
    out = [wire.MAGIC]
    for opcode, _, content in wire.records("x", data):
        if opcode == wire.CHUNK:
            r = wire.Reader("x", content)
            fixed = bytes(r.take(24))
            assert r.string() == ""
            size = r.u64()
            block = bytes(r.take(r.u64()))
            body = zlib.compress(block) if codec == "deflate" else __import__("zstandard").ZstdCompressor().compress(block)
            content = fixed + wire.put_string(codec) + struct.pack("<QQ", size, len(body)) + body
        out.append(wire.put_record(opcode, bytes(content)))
    return b"".join(out) + wire.MAGIC


@pytest.mark.parametrize("codec", ["deflate", "zstd"])
def test_chunk_level_compression(tmp_path, codec):
    plain = tmp_path / "plain.4dgs"
    fourdgs.write(plain, _gaussians(800, seed=42), 3.0, options=fourdgs.WriteOptions(write_index=False))
    path = tmp_path / f"{codec}.4dgs"
    path.write_bytes(_compress_chunks(plain.read_bytes(), codec))
    scene = fourdgs.read(str(path), recover_truncated=False)
    _same_file(read_dynamic(path), scene)
    np.testing.assert_array_equal(read_dynamic(path).positions, read_dynamic(plain).positions)


def _linear_seconds_capture(tmp_path, n=2500):
    rec = raw_spacetime(n, seed=43, names=LINEAR)
    write_raw_ply(tmp_path / "lin.ply", rec, ("comment cfg_args: start=0 duration=2 fps=30 sh_degree=1",))
    return read_dynamic(tmp_path / "lin.ply")


@pytest.mark.parametrize("options", [{}, {"codec": "zstd"}, {"profile": "fine"}, {"profile": "coarse"}])
def test_splatline_written_files_read_by_fourdgs(tmp_path, options):
    ours = to_fourdgs(_linear_seconds_capture(tmp_path))
    path = tmp_path / "ours.4dgs"
    if options:
        write_fourdgs(path, ours, **options)
    else:
        write_dynamic(path, ours)
    data = path.read_bytes()
    assert validate(data).findings == []
    scene = fourdgs.read(str(path), recover_truncated=False)
    assert scene.summary_crc_ok is True and len(scene.chunk_index) == 1
    back = read_dynamic(path)
    _same_file(back, scene)
    # the file holds the capture, splat for splat in its order, to the profile's bounds
    pos_bound = float(scene.quantization.bounds["pos"])
    assert np.abs(back.positions - ours.positions).max() <= pos_bound * 1.001 + 1e-6
    assert np.abs(back.opacities - ours.opacities).max() <= float(scene.quantization.bounds["alpha"]) + 1e-6
    assert same_rotation(back.rotations.astype(np.float64), ours.rotations.astype(np.float64)).max() <= \
        float(scene.quantization.bounds["rot"]) * 2
    assert np.abs(back.t_center - ours.t_center).max() <= float(scene.quantization.bounds["time"]) * 1.001
    assert back.sh_degree == ours.sh_degree == 1
    assert np.abs(back.sh_rest - np.clip(ours.sh_rest, -4, 4)).max() <= 4.0 / 255 + 1e-6


def test_write_keeps_windows_and_never_fading_splats(tmp_path):
    theirs = tmp_path / "theirs.4dgs"
    fourdgs.write(theirs, _gaussians(1500, seed=44), 3.0)
    capture = read_dynamic(theirs)
    ours = tmp_path / "ours.4dgs"
    write_dynamic(ours, capture)
    back = read_dynamic(ours)
    np.testing.assert_array_equal(back.window, capture.window)
    np.testing.assert_array_equal(np.isinf(back.t_scale), np.isinf(capture.t_scale))
    _same_file(back, fourdgs.read(str(ours), recover_truncated=False))


def test_writer_refusals(tmp_path):
    lin = _linear_seconds_capture(tmp_path, 200)
    cubic = replace(lin, model="spacetime", motion=np.concatenate([lin.motion, np.ones_like(lin.motion),
                                                                   np.zeros_like(lin.motion)], axis=1),
                    omega=np.zeros((lin.count, 4), np.float32))
    segment = read_dynamic(tmp_path / "lin.ply")
    segment = replace(segment, unit="segment")
    for capture, reason in ((cubic, "quadratic/cubic motion"), (segment, "segment units")):
        path = tmp_path / "refused.4dgs"
        with pytest.raises(SplatFormatError, match=reason) as err:
            write_dynamic(path, capture)
        assert "\n" not in str(err.value) and str(path) in str(err.value)
        assert not path.exists() and not list(tmp_path.glob("refused*"))


# --- hostile files ---------------------------------------------------------------------

@pytest.fixture
def good(tmp_path):
    path = tmp_path / "good.4dgs"
    fourdgs.write(path, _gaussians(600, seed=45, sh_degree=1), 3.0)
    return path.read_bytes()


def _refused(tmp_path, data, match, reader=read_dynamic, **kwargs):
    path = tmp_path / "bad.4dgs"
    path.write_bytes(data)
    with pytest.raises(SplatFormatError, match=match) as err:
        reader(path, **kwargs)
    assert "\n" not in str(err.value) and str(err.value).startswith(str(path))
    return str(err.value)


def _header_at(data) -> int:
    """Offset of the Header's u64 gaussian count."""
    r = wire.Reader("x", data, len(wire.MAGIC) + 9)
    r.string(), r.string(), r.f64()
    return r.pos


def test_truncated_files(tmp_path, good):
    for cut in (4, 20, len(good) // 3, len(good) // 2, len(good) - 9, len(good) - 1):
        _refused(tmp_path, good[:cut], "truncated|bad magic")


def test_bad_magic_and_newer_version(tmp_path, good):
    _refused(tmp_path, b"\x894DGX1\r\n" + good[8:], "not a dynamic capture")
    _refused(tmp_path, b"\x894DGX1\r\n" + good[8:], "not a .4dgs file \\(bad magic\\)", reader=read_fourdgs)
    _refused(tmp_path, b"\x894DGS2\r\n" + good[8:-8] + b"\x894DGS2\r\n", "major version b'2'")


def test_huge_claimed_counts(tmp_path, good):
    at = _header_at(good)
    huge = good[:at] + struct.pack("<Q", 1 << 40) + good[at + 8:]
    _refused(tmp_path, huge, "memory budget")
    _refused(tmp_path, huge, "more than the splat budget", max_splats=10**6)
    fewer = good[:at] + struct.pack("<Q", 10) + good[at + 8:]
    _refused(tmp_path, fewer, "more splats than the Header's 10")
    # a record claiming more bytes than the file holds
    body = bytearray(good)
    struct.pack_into("<Q", body, len(wire.MAGIC) + 1, 1 << 50)
    _refused(tmp_path, bytes(body), "claims 1125899906842624 bytes")


def test_bad_crc_and_corrupt_payload(tmp_path, good):
    footer_at = len(good) - len(wire.MAGIC) - 29
    start = struct.unpack_from("<Q", good, footer_at + 9)[0]
    crc_flipped = bytearray(good)
    crc_flipped[footer_at + 9 + 16] ^= 0xFF
    _refused(tmp_path, bytes(crc_flipped), "CRC-32")
    index_flipped = bytearray(good)
    index_flipped[start + 9 + 3] ^= 0x01  # the first entry's t0, inside the summary
    _refused(tmp_path, bytes(index_flipped), "CRC-32")
    # a byte inside the first chunk's first stream payload
    chunk = next(offset for opcode, offset, _ in wire.records("x", good) if opcode == wire.CHUNK)
    payload = bytearray(good)
    payload[chunk + 9 + 24 + 4 + 16 + 17 + 2] ^= 0xFF
    _refused(tmp_path, bytes(payload), "corrupt deflate|inflates|decompresses|end marker")


def test_refused_variants(tmp_path):
    path = tmp_path / "kd.4dgs"
    fourdgs.write(path, _gaussians(300, seed=46, sh_degree=0), 1.0,
                  options=fourdgs.WriteOptions(temporal_model="keyframe-delta"))
    _refused(tmp_path, path.read_bytes(), "temporal model 'keyframe-delta'")


def test_empty_captures(tmp_path):
    z = np.zeros
    fourdgs.write(tmp_path / "theirs.4dgs", fourdgs.GaussianSet(
        positions=z((0, 3), np.float32), scales=z((0, 3), np.float32), rotations=z((0, 4), np.float32),
        colors=z((0, 4), np.float32), motions=z((0, 3), np.float32), mu_t=z(0, np.float32),
        sigma_t=z(0, np.float32), win_lo=z(0, np.float32), win_hi=z(0, np.float32)), 1.0)
    empty = read_dynamic(tmp_path / "theirs.4dgs")
    assert (empty.count, empty.t_end) == (0, 1.0)
    write_dynamic(tmp_path / "ours.4dgs", empty)
    assert fourdgs.read(str(tmp_path / "ours.4dgs"), recover_truncated=False).gaussians.count == 0
    assert read_dynamic(tmp_path / "ours.4dgs").count == 0
