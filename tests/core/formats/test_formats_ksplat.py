"""GaussianSplats3D .ksplat, read only: files from testing/ksplat_write.py (the published
layout; the npm library needs three.js and a browser to build one), at every compression level
and SH degree it stores.

Two checks per file: Splatline's decode equals splat-transform's decode of the same file
within float rounding (both undo the same bytes), and is within each level's quantisation of
the splats written (bounds derived from the layout, below). splat-transform is required under
CI=true (tests/project/test_peers_present.py); elsewhere that half skips, saying why."""
from __future__ import annotations

import os
import subprocess

import numpy as np
import pytest

from addon.core.errors import SplatFormatError
from addon.core.formats import read, read_with_report, readfile, write
from addon.core.sh import C0
from bench.formats_bench import run_splat_transform
from testing.ksplat_write import POSITION_RANGE, write_ksplat
from testing.paths import REPO
from testing.peers import gs3d_modules, missing_reason, splat_transform
from testing.read_faults import hook
from testing.reader_checks import fails
from testing.synth import random_splats

PEER = splat_transform()
LEVELS = [0, 1, 2]
DEGREES = [0, 1, 2]
SH_RANGE = (-1.5, 1.5)
HALF_REL = 2.0 ** -11  # float16 rounds to nearest: half an ulp of its 10-bit mantissa
HALF_ABS = 2.0 ** -25  # and half its smallest subnormal


@pytest.fixture(scope="module")
def source():
    s = random_splats(3000, 3, seed=7)
    s.opacities = np.clip(s.opacities, 0.01, 0.99)  # away from the peer's logit clamp
    return s


def _file(tmp_path, source, level, degree, **kw):
    path = tmp_path / f"l{level}d{degree}.ksplat"
    write_ksplat(path, source, level=level, degree=degree, sections=2, bucket_size=100, sh_range=SH_RANGE, **kw)
    return path


def _blocks(path) -> np.ndarray:
    """Each section's bucket block size, from its header (u32 slot count at byte 4)."""
    raw = path.read_bytes()
    slots = int(np.frombuffer(raw, "<u4", 2, 0)[1])
    return np.array([np.frombuffer(raw, "<f4", 1, 4096 + 1024 * i + 16)[0] for i in range(slots)])


@pytest.mark.parametrize("degree", DEGREES)
@pytest.mark.parametrize("level", LEVELS)
def test_decode_is_within_the_levels_quantisation(tmp_path, source, level, degree):
    path = _file(tmp_path, source, level, degree)
    got, report = read_with_report(path)
    assert report.format == "ksplat" and got.count == source.count and got.sh_degree == degree
    want = source.with_sh_degree(degree)
    if level == 0:
        np.testing.assert_array_equal(got.positions, want.positions)
        np.testing.assert_array_equal(got.scales, want.scales)
        np.testing.assert_allclose(got.rotations, want.rotations, atol=4e-7)
        np.testing.assert_array_equal(got.sh_rest, want.sh_rest)
    else:
        # u16 offsets from a bucket centre, step block / 2 / range; rounding to nearest
        step = _blocks(path).max() / 2 / POSITION_RANGE
        pos_err = np.abs(got.positions - want.positions).max()
        assert pos_err <= step / 2 + 4 * np.finfo(np.float32).eps * np.abs(want.positions).max(), (pos_err, step)
        assert pos_err > 0  # it really was quantised
        np.testing.assert_array_less(np.abs(got.scales - want.scales), HALF_REL * np.abs(want.scales) + HALF_ABS)
        # a quaternion of float16 components, renormalised: each moves by at most ~2 half-ulps
        np.testing.assert_allclose(got.rotations, want.rotations, atol=2 * HALF_REL + 1e-6)
        if level == 1:
            np.testing.assert_array_less(np.abs(got.sh_rest - want.sh_rest), HALF_REL * np.abs(want.sh_rest) + HALF_ABS)
        else:  # u8 over the header's range, rounded to nearest (values kept inside the range)
            sh_step = (SH_RANGE[1] - SH_RANGE[0]) / 255
            assert np.abs(got.sh_rest - np.clip(want.sh_rest, *SH_RANGE)).max(initial=0) <= sh_step / 2 + 1e-6
    # colour and opacity are u8 at every level
    assert np.abs(got.opacities - want.opacities).max() <= 0.5 / 255 + 1e-6
    assert np.abs(got.sh_dc - np.clip(want.sh_dc, -0.5 / C0, 0.5 / C0)).max() <= 0.5 / 255 / C0 + 1e-5


@pytest.mark.skipif(PEER is None, reason=missing_reason("splat-transform"))
@pytest.mark.parametrize("degree", DEGREES)
@pytest.mark.parametrize("level", LEVELS)
def test_decode_matches_splat_transform(tmp_path, source, level, degree):
    """Both decoders read the same bytes: they differ by float rounding only (splat-transform
    goes through a float PLY: log scales, logit opacities, which Splatline's PLY reader undoes)."""
    path = _file(tmp_path, source, level, degree)
    ours = read(path)
    run_splat_transform(PEER, path, tmp_path / "peer.ply")
    _same_decode(ours, read(tmp_path / "peer.ply"), degree)


def _same_decode(ours, theirs, degree) -> None:
    assert theirs.count == ours.count and theirs.sh_degree == ours.sh_degree == degree
    eps = np.finfo(np.float32).eps
    np.testing.assert_allclose(ours.positions, theirs.positions, rtol=0, atol=8 * eps * np.abs(ours.positions).max())
    np.testing.assert_allclose(ours.scales, theirs.scales, rtol=4 * eps)
    np.testing.assert_allclose(ours.rotations, theirs.rotations, atol=4 * eps)
    np.testing.assert_allclose(ours.opacities, theirs.opacities, atol=16 * eps)
    np.testing.assert_allclose(ours.sh_dc, theirs.sh_dc, atol=16 * eps)
    np.testing.assert_allclose(ours.sh_rest, theirs.sh_rest, rtol=4 * eps, atol=4 * eps)


def test_max_degree_and_budget(tmp_path, source):
    path = _file(tmp_path, source, 1, 2)
    full = read(path)
    low = read(path, sh_degree=1)
    assert low.sh_degree == 1
    np.testing.assert_array_equal(low.sh_rest, full.sh_rest[:, :3])
    fails(path, "splat budget", max_splats=source.count - 1)
    assert read(path, max_splats=source.count).count == source.count


# --- bad input: one SplatFormatError naming the file ------------------------------------

def _patched(tmp_path, source, offset, value, dtype):
    path = _file(tmp_path, source, 1, 1)
    raw = bytearray(path.read_bytes())
    raw[offset:offset + np.dtype(dtype).itemsize] = np.array([value], dtype).tobytes()
    path.write_bytes(raw)
    return path


def test_hostile_ksplat_files(tmp_path, source):
    good = _file(tmp_path, source, 1, 1).read_bytes()
    cut = tmp_path / "cut.ksplat"
    cut.write_bytes(good[:1000])
    fails(cut, "truncated")
    cut.write_bytes(good[:-5])
    fails(cut, "past the end")
    fails(_patched(tmp_path, source, 0, 1, "u1"), "version 1.1")
    fails(_patched(tmp_path, source, 20, 3, "<u2"), "compression level 3")
    fails(_patched(tmp_path, source, 4, 2 ** 31, "<u4"), "section headers")  # slots far past the file
    fails(_patched(tmp_path, source, 16, 12345, "<u4"), "12345")  # header count disagrees
    fails(_patched(tmp_path, source, 4096, 10 ** 9, "<u4"), "slots")  # section count > its slots
    fails(_patched(tmp_path, source, 4096 + 4, 10 ** 9, "<u4"), "past the end")  # section slots past the file
    fails(_patched(tmp_path, source, 4096 + 40, 3, "<u2"), "sh degree 3")
    fails(_patched(tmp_path, source, 4096 + 12, 0, "<u4"), "bucket")  # bucket layout inconsistent
    # a bucket size of 4G splats: the buckets are searched, nothing is sized from it
    assert read(_patched(tmp_path, source, 4096 + 8, 2 ** 32 - 1, "<u4")).count == source.count


def test_a_ksplat_that_shrinks_while_read_is_one_error(tmp_path, source, monkeypatch):
    path = _file(tmp_path, source, 2, 2)
    monkeypatch.setattr(readfile, "BLOCK", 4096)
    monkeypatch.setattr(readfile, "after_block", hook(path, "truncate", 1))
    with pytest.raises(SplatFormatError, match="shrank while it was read") as info:
        read(path)
    assert info.value.path == os.fspath(path)


# --- files GaussianSplats3D writes itself (the pinned npm peer, testing/ksplat_peer.mjs) ---

GS3D = gs3d_modules()


@pytest.fixture(scope="module")
def source_ply(tmp_path_factory, source):
    path = tmp_path_factory.mktemp("gs3d") / "src.ply"
    write(path, source.with_sh_degree(2))
    return path


@pytest.mark.skipif(GS3D is None, reason=missing_reason("gaussian-splats-3d"))
@pytest.mark.skipif(PEER is None, reason=missing_reason("splat-transform"))
@pytest.mark.parametrize("degree", DEGREES)
@pytest.mark.parametrize("level", LEVELS)
def test_gaussian_splats_3d_files_decode_as_splat_transform_decodes_them(tmp_path, source, source_ply, level, degree):
    """The library buckets and reorders the splats, so the source is compared as a set of
    positions (within the level's quantisation) and splat-transform's decode index for index."""
    path = tmp_path / "gs3d.ksplat"
    subprocess.run(["node", str(REPO / "testing" / "ksplat_peer.mjs"), str(GS3D), str(source_ply), str(path),
                    str(level), str(degree)], check=True, capture_output=True, timeout=300)
    ours = read(path)
    assert ours.count == source.count and ours.sh_degree == degree
    run_splat_transform(PEER, path, tmp_path / "peer.ply")
    theirs = read(tmp_path / "peer.ply")
    _same_decode(ours, theirs, degree)
    # reordered: each axis's sorted coordinates match the source's within the level's step
    # (the library's bucket block is 5 units: a u16 step of 5 / 2 / 32767)
    step = 0.0 if level == 0 else 5.0 / 2 / POSITION_RANGE
    assert np.abs(np.sort(ours.positions, axis=0) - np.sort(source.positions, axis=0)).max() <= step / 2 + 1e-5
