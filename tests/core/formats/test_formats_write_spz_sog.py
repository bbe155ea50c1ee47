"""SPZ and SOG writers: what Splatline writes reads back through its own readers within each
format's quantization step (bounds derived from the steps, or from the codebook the file
itself holds), and matches splat-transform's layout."""
from __future__ import annotations

import gzip
from dataclasses import replace

import numpy as np
import pytest

from addon.core.formats import detect_format, format_for_output, read, write
from addon.core.formats.sog_write import palette_size
from addon.core.formats.spz import _read_v4
from addon.core.formats.spz_write import encode_spz
from addon.core.reframe import reframe
from addon.core.quantize import assign, codebook_1d, kmeans, nearest_1d
from testing.format_steps import assert_sog_within_steps, assert_spz_within_steps, sog_meta
from testing.webp_support import needs_straight_webp

CAPTURES = ["guitar", "test64"]


@pytest.fixture(scope="module", params=CAPTURES)
def capture(request, testdata):
    return request.param, read(testdata / f"{request.param}.ply")


def test_spz_v4_attribute_bytes_match_splat_transform(testdata, capture):
    """splat-transform runs Niantic's own packer: our streams must be the same bytes. Its 3.7
    files hold the PLY's values unturned, so ours are encoded from the same values declared
    RUB (our writer turns a RDF set into RUB first: test_spz_round_trip_within_steps)."""
    name, src = capture
    theirs = _read_v4("theirs", (testdata / f"{name}.spz").read_bytes())
    ours = _read_v4("ours", encode_spz(replace(src, axes="RUB")))
    assert ours[0] == theirs[0]  # version, count, degree, fractional bits, flags
    for a, b in zip(ours[1], theirs[1]):
        assert np.array_equal(a, b)


@pytest.mark.parametrize("version", [4, 3])
def test_spz_round_trip_within_steps(capture, tmp_path, version):
    name, src = capture
    out = tmp_path / "o.spz"
    write(out, src, version=version)
    raw = out.read_bytes()
    assert raw[:4] == b"NGSP" if version == 4 else gzip.decompress(raw)[4] == 3
    back = read(out)
    assert back.axes == "RUB"  # the frame SPZ documents, turned back to the source's to compare
    rub = reframe(src, "RUB")
    np.testing.assert_array_equal(rub.positions[:, 1:], -src.positions[:, 1:])  # a half turn about x
    assert_spz_within_steps(back, src)  # in src's RDF frame


@needs_straight_webp
def test_sog_round_trip_within_steps(capture, tmp_path):
    name, src = capture
    out = tmp_path / "o.sog"
    write(out, src)
    assert detect_format(out) == "sog"
    meta = sog_meta(out)
    assert_sog_within_steps(read(out), src, meta)
    if src.sh_degree:
        assert meta["shN"]["count"] == palette_size(src.count) and meta["shN"]["bands"] == src.sh_degree
        assert src.count <= palette_size(src.count)  # test64: every splat its own entry


@needs_straight_webp
def test_sog_smaller_than_float_ply_and_near_splat_transform(testdata, tmp_path):
    out = tmp_path / "g.sog"
    write(out, read(testdata / "guitar.ply"))
    assert out.stat().st_size <= 1.05 * (testdata / "guitar.sog").stat().st_size


@needs_straight_webp
def test_sog_unbundled_reads_like_bundled(testdata, tmp_path):
    src = read(testdata / "test64.ply")
    write(tmp_path / "a.sog", src)
    meta = tmp_path / "un" / "meta.json"
    meta.parent.mkdir()
    assert format_for_output(meta) == "sog"
    write(meta, src)
    assert sorted(p.name for p in meta.parent.iterdir()) == sorted(
        ["meta.json", "means_l.webp", "means_u.webp", "quats.webp", "scales.webp", "sh0.webp",
         "shN_centroids.webp", "shN_labels.webp"])
    a, b = read(tmp_path / "a.sog"), read(meta)
    for field in ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest"):
        assert np.array_equal(getattr(a, field), getattr(b, field)), field


@needs_straight_webp
def test_sog_and_spz_writes_are_deterministic(testdata, tmp_path):
    src = read(testdata / "test64.ply")
    for ext in (".sog", ".spz"):
        write(tmp_path / f"a{ext}", src)
        write(tmp_path / f"b{ext}", src)
        assert (tmp_path / f"a{ext}").read_bytes() == (tmp_path / f"b{ext}").read_bytes()


def test_codebook_1d_lossless_when_few_values():
    few = np.random.default_rng(1).choice(np.linspace(-3, 2, 100), 5000)
    book = codebook_1d(few)
    assert len(book) == 256 and np.all(np.diff(book) >= 0)
    assert np.array_equal(book[nearest_1d(few, book).astype(np.int64)], few.astype(np.float32))


def test_codebooks_match_splat_transform_on_guitar(testdata, tmp_path):
    """Same histogram + DP as splat-transform: the scales and sh0 codebooks of its guitar.sog."""
    src = read(testdata / "guitar.ply")
    theirs = sog_meta(testdata / "guitar.sog")
    for key, values in (("scales", np.log(src.scales)), ("sh0", src.sh_dc)):
        ours = codebook_1d(values)
        assert np.allclose(ours, theirs[key]["codebook"], rtol=1e-5, atol=1e-6), key


@pytest.mark.parametrize("k", [64, 5000])  # flat, and the two-level path above 4096
def test_kmeans_seeded_and_better_than_its_seed(k):
    rng = np.random.default_rng(2)
    pts = (rng.normal(size=(20_000, 9)) * rng.uniform(0.1, 1, 9)).astype(np.float32)
    cen, lab = kmeans(pts, k, seed=3)
    cen2, lab2 = kmeans(pts, k, seed=3)
    assert np.array_equal(cen, cen2) and np.array_equal(lab, lab2)
    assert len(cen) <= k and lab.max() < len(cen)
    sse = ((pts - cen[lab]) ** 2).sum()
    seeds = pts[rng.choice(len(pts), len(cen), replace=False)]
    base = ((pts - seeds[assign(pts, seeds)]) ** 2).sum()
    assert sse < 0.9 * base
