"""SOG v2 reader: splat-transform's own decodes of the same bytes are the reference, and bad
input (missing images, zip bombs, nonsense meta.json) raises SplatFormatError naming the file."""
from __future__ import annotations

import json
import math
import shutil
import zipfile

import numpy as np
import pytest

from addon.core.errors import SplatFormatError
from addon.core.formats import detect_format, read
from addon.core.formats.ply import read_ply
from addon.core.formats.sog import read_sog
from testing.webp_support import STRAIGHT_WEBP, needs_straight_webp

CASES = [("guitar.sog", "guitar_sog.peer.ply"), ("test64.sog", "test64_sog.peer.ply"),
         ("test64_sog_unbundled/meta.json", "test64_sog.peer.ply")]
FAR_BELOW = 1e-3  # "far below the quantization step": a thousandth of it


def _meta(testdata, name):
    if name.endswith(".sog"):
        with zipfile.ZipFile(testdata / name) as z:
            return json.loads(z.read("meta.json"))
    return json.loads((testdata / name).read_text())


def _min_gap(codebook) -> float:
    gaps = np.diff(np.unique(np.asarray(codebook, np.float64)))
    return float(gaps.min())


@needs_straight_webp
@pytest.mark.parametrize("name,peer", CASES)
def test_decode_matches_peer_far_below_quantization(testdata, name, peer):
    got, ref, meta = read_sog(testdata / name), read_ply(testdata / peer), _meta(testdata, name)
    assert got.count == ref.count == meta["count"]
    assert got.sh_degree == ref.sh_degree
    # positions: one 16-bit step of the log-space range, mapped through exp at the far end
    lo, hi = np.array(meta["means"]["mins"]), np.array(meta["means"]["maxs"])
    step = (hi - lo) / 65535 * np.exp(np.maximum(abs(lo), abs(hi)))
    assert (np.abs(got.positions - ref.positions) <= FAR_BELOW * step).all()
    # scales and colours: the smallest gap between codebook entries
    log_err = np.abs(np.log(got.scales.astype(np.float64)) - np.log(ref.scales))
    assert log_err.max() <= FAR_BELOW * _min_gap(meta["scales"]["codebook"])
    assert np.abs(got.sh_dc - ref.sh_dc).max() <= FAR_BELOW * _min_gap(meta["sh0"]["codebook"])
    # quaternions: 8 bits over [-1/sqrt2, 1/sqrt2]; opacity: 8 bits
    assert np.abs(got.rotations - ref.rotations).max() <= FAR_BELOW * math.sqrt(2) / 255
    assert np.abs(got.opacities - ref.opacities).max() <= FAR_BELOW / 255
    if "shN" in meta:
        gap = _min_gap(meta["shN"]["codebook"])
        assert np.abs(got.sh_rest - ref.sh_rest).max() <= FAR_BELOW * gap


@needs_straight_webp
def test_dispatch_and_degree_cap(testdata):
    assert detect_format(testdata / "guitar.sog") == "sog"
    assert detect_format(testdata / "test64_sog_unbundled/meta.json") == "sog"
    capped = read(testdata / "test64.sog", sh_degree=1)
    full = read_sog(testdata / "test64.sog")
    assert capped.sh_rest.shape == (64, 3, 3)
    np.testing.assert_array_equal(capped.sh_rest, full.sh_rest[:, :3])


def _unbundled(testdata, tmp_path):
    folder = tmp_path / "sog"
    shutil.copytree(testdata / "test64_sog_unbundled", folder)
    for f in folder.iterdir():
        f.chmod(0o644)
    return folder


def _edit_meta(folder, edit):
    meta = json.loads((folder / "meta.json").read_text())
    edit(meta)
    (folder / "meta.json").write_text(json.dumps(meta))
    return folder / "meta.json"


def _raises(path, *words):
    with pytest.raises(SplatFormatError) as err:
        read(path)
    text = str(err.value)
    assert str(path.parent if path.name == "meta.json" else path) in text
    for w in words:
        assert w in text, text
    return text


def test_missing_image_names_it(testdata, tmp_path):
    folder = _unbundled(testdata, tmp_path)
    (folder / "quats.webp").unlink()
    _raises(folder / "meta.json", "quats.webp", "no such file")


def test_bundle_missing_member(testdata, tmp_path):
    bad = tmp_path / "bad.sog"
    with zipfile.ZipFile(testdata / "test64.sog") as src, zipfile.ZipFile(bad, "w") as dst:
        for info in src.infolist():
            if info.filename != "sh0.webp":
                dst.writestr(info.filename, src.read(info.filename))
    _raises(bad, "lacks sh0.webp")


@needs_straight_webp
def test_zip_bomb_refused_before_inflating(testdata, tmp_path):
    bomb = tmp_path / "bomb.sog"
    with zipfile.ZipFile(testdata / "test64.sog") as src, \
            zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as dst:
        for info in src.infolist():
            data = src.read(info.filename)
            dst.writestr(info.filename, b"\0" * (64 << 20) if info.filename == "sh0.webp" else data)
    assert bomb.stat().st_size < 1 << 20
    _raises(bomb, "sh0.webp", "claims")


@pytest.mark.parametrize("edit,words", [
    (lambda m: m.update(count=10 ** 9), ["count"]),
    (lambda m: m.update(count=-1), ["count"]),
    (lambda m: m.update(count=5000), ["too small for 5000"]),
    (lambda m: m.pop("version"), ["v1"]),
    (lambda m: m.update(version=3), ["version 3"]),
    (lambda m: m["means"].update(mins=[0, 0]), ["means.mins"]),
    (lambda m: m["means"].update(maxs=[0, "x", 1]), ["means.maxs"]),
    (lambda m: m["quats"].update(files=["../quats.webp"]), ["plain file name"]),
    (lambda m: m["scales"].update(codebook=[1.0] * 4), ["codebook"]),
    (lambda m: m["shN"].update(bands=7), ["bands"]),
    (lambda m: m["sh0"].update(codebook=[]), ["sh0.codebook"]),
])
@needs_straight_webp
def test_nonsense_meta(testdata, tmp_path, edit, words):
    _raises(_edit_meta(_unbundled(testdata, tmp_path), edit), *words)


def test_not_json_and_not_zip(tmp_path):
    meta = tmp_path / "meta.json"
    meta.write_text("{not json")
    _raises(meta, "not JSON")
    fake = tmp_path / "x.sog"
    fake.write_bytes(b"PK\x03\x04" + b"\0" * 64)
    _raises(fake, "not a SOG zip")


def test_count_beyond_image_bytes_allocates_nothing(testdata, tmp_path):
    # 2 million splats claimed by a few hundred bytes of images: refused from the sizes alone
    path = _edit_meta(_unbundled(testdata, tmp_path), lambda m: m.update(count=2_000_000))
    _raises(path, "claims 2000000 splats")


@pytest.mark.skipif(STRAIGHT_WEBP, reason="this OpenImageIO keeps WebP alpha: SOG reads here")
def test_sog_refused_where_webp_alpha_is_premultiplied(testdata):
    """Blender 4.5's OpenImageIO multiplies alpha into sh0's codebook indices: one clear
    error naming the file, never a wrong decode."""
    with pytest.raises(SplatFormatError, match="does not keep WebP alpha") as err:
        read(testdata / "guitar.sog")
    assert "guitar.sog" in str(err.value)
