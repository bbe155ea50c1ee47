"""XGRIDS LCC and LCC2 scenes (core/formats/lcc.py, lcc2.py), written by testing/lcc_files.py
to the layout splat-transform 3.7.0 reads (no scanner's file is public to us):
  - each decodes to its source splats within the format's quantisation (half a step of each
    quantity, from the scene's own bounds), LOD 0 by default, any LOD by `lod`;
  - splat-transform's decode of the same scene (to a float .ply, its default: LOD 0; `-L n`)
    equals Splatline's, splat for splat, within float32 rounding, after turning Splatline's
    RFU data into the PLY's RDF frame as splat-transform does (peer; skips without it, and
    tests/project/test_peers_present.py fails CI then);
  - bad scenes are one SplatFormatError naming the file at fault.
"""
from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pytest

from addon.core.errors import SplatFormatError
from addon.core.formats import read
from addon.core.reframe import reframe
from addon.core.sh import C0
from addon.core.splats import AXES_RFU
from bench.formats_bench import run_splat_transform
from testing.lcc_files import lcc_steps, write_lcc, write_lcc2
from testing.peers import missing_reason, splat_transform
from testing.synth import random_splats
from testing.webp_support import needs_straight_webp

PEER = splat_transform()
needs_peer = pytest.mark.skipif(PEER is None, reason=missing_reason("splat-transform"))
EPS32 = float(np.finfo(np.float32).eps)
# LCC2 chunks: SPZ, SOG (WebP images: refused where OpenImageIO premultiplies their alpha,
# Blender 4.5), and the old protocol's SOG
LCC2_KINDS = [pytest.param(dict(splat_type=".spz"), id="spz"),
              pytest.param(dict(splat_type=".sog"), id="sog", marks=needs_straight_webp),
              pytest.param(dict(old_protocol=True, trailing_commas=True), id="old_protocol_sog",
                           marks=needs_straight_webp)]


def _lods(degree=3):
    # opacities away from 0 and 1: splat-transform stores a logit, infinite there
    return [random_splats(n, degree, seed=seed, opacity=(0.02, 0.98), dc=0.6)
            for seed, n in ((1, 400), (2, 90), (3, 25))]


def _rest15(s):
    out = np.zeros((s.count, 15, 3), np.float32)
    out[:, :s.sh_rest.shape[1]] = s.sh_rest[:, :15]
    return out


def _within_steps(back, src, steps, sh=True):
    """back (decoded) against src (written), each quantity within half its quantisation step."""
    assert back.count == src.count and back.axes == AXES_RFU
    np.testing.assert_array_equal(back.positions, src.positions)  # stored as float32
    # half a step, plus float32's rounding of the decoded value
    assert (np.abs(back.scales - src.scales) <= steps["scale"] + EPS32 * src.scales).all()
    assert np.abs(back.opacities - src.opacities).max() <= steps["opacity"] + 1e-6
    # a byte of colour holds SH DC in [-0.5, 0.5] / C0: the few beyond are clamped
    held = np.clip(src.sh_dc, -0.5 / C0, 0.5 / C0)
    assert np.abs(back.sh_dc - held).max() <= steps["colour"] + 1e-5
    # each stored component within half a step: |q - q'| <= sqrt(3) * half step, up to sign
    dot = np.abs((back.rotations.astype(np.float64) * src.rotations).sum(1))
    assert (dot >= 1 - (3 * steps["rotation"] ** 2) / 2 - 1e-6).all(), dot.min()
    if sh:
        assert back.sh_degree == 3
        err = np.abs(back.sh_rest - _rest15(src)).max(axis=(0, 1))
        assert (err <= steps["sh"] * (1 + 1e-6) + 1e-7).all(), (err, steps["sh"])
    else:
        assert back.sh_degree == 0


@pytest.mark.parametrize("sh", [True, False], ids=["quality_sh", "portable"])
def test_lcc_reads_its_source_within_the_quantisation(tmp_path, sh):
    lods = _lods()
    path = write_lcc(tmp_path / "s", lods, sh=sh)
    steps = lcc_steps(path)
    for lod in (None, 0, 1, 2):
        _within_steps(read(path, lod=lod), lods[lod or 0], steps, sh)


def test_lcc_sh_degree_limit_and_shcoef_presence(tmp_path):
    lods = _lods()
    path = write_lcc(tmp_path / "s", lods)
    assert read(path, sh_degree=1).sh_degree == 1
    os.remove(tmp_path / "s" / "shcoef.bin")
    assert read(path, sh_degree=0).count == 400  # degree 0: shcoef.bin is not opened
    # no fileType: SH when a shcoef attribute is listed (splat-transform's rule)
    meta = json.loads(open(path).read())
    del meta["fileType"]
    open(path, "w").write(json.dumps(meta))
    with pytest.raises(SplatFormatError, match="shcoef.bin: no such file"):
        read(path)


@pytest.mark.parametrize("kind", LCC2_KINDS)
def test_lcc2_reads_each_lod_of_its_chunks(tmp_path, kind):
    lods = _lods()
    path = write_lcc2(tmp_path / "s", lods, env=random_splats(7, 3, seed=5), **kind)
    for lod in (0, 1, 2):
        back = read(path, lod=lod)
        assert back.count == lods[lod].count and back.axes == AXES_RFU  # the env chunk left out
        # SPZ stores positions to 1/4096 here (12 fractional bits), SOG's log-space 16 bits
        # finer; SOG writes its splats in Morton order, so each one is matched to its nearest
        gap = np.linalg.norm(back.positions[:, None] - lods[lod].positions[None], axis=2)
        assert gap.min(1).max() < 2e-3 and len(set(gap.argmin(1))) == back.count


@pytest.mark.parametrize("kind", ["lcc", "lcc2"])
def test_info_lists_each_lod_and_describes_the_one_read(tmp_path, kind):
    """`info` lists every LOD's count from the meta files without decoding, and they are
    the counts a read of that LOD gives."""
    from addon.cli.info import summarize
    lods = _lods()
    path = write_lcc(tmp_path / "s", lods) if kind == "lcc" else write_lcc2(tmp_path / "s", lods, splat_type=".spz")
    counts = [s.count for s in lods]
    for lod in (None, 2):
        info = summarize(path, lod=lod)
        assert (info["levels"], info["level"], info["count"]) == (counts, lod or 0, counts[lod or 0])
        assert read(path, lod=lod).count == info["count"]


def test_lod_out_of_range_and_lod_on_a_format_without_levels(tmp_path):
    path = write_lcc(tmp_path / "s", _lods())
    with pytest.raises(SplatFormatError, match=r"LODs 0\.\.2 .*no LOD 3"):
        read(path, lod=3)
    ply = tmp_path / "x.ply"
    from addon.core.formats import write
    write(ply, random_splats(4, 0))
    with pytest.raises(SplatFormatError, match="has one level of detail"):
        read(ply, lod=1)


# --- against splat-transform ------------------------------------------------------------

def _peer_decode(path, tmp_path, lod=None):
    out = tmp_path / f"peer_{os.path.basename(os.path.dirname(path))}_{lod}.ply"
    run_splat_transform(PEER, *(["-L", str(lod)] if lod is not None else []), path, out)
    return read(out)


def _same_as_peer(ours, theirs):
    """Same splats in the same order, within float32 rounding of the two decoders: both
    dequantise the same integers; splat-transform turns them by its Euler transform in float
    (positions, quaternions and SH bands), writes log scales and logit opacities."""
    o = reframe(ours, "RDF")
    assert theirs.count == o.count and theirs.sh_degree == o.sh_degree
    span = float(np.abs(o.positions).max())
    assert np.abs(o.positions - theirs.positions).max() <= 4 * EPS32 * span
    assert np.abs(o.scales / theirs.scales - 1).max() <= 8 * EPS32
    assert (1 - np.abs((o.rotations.astype(np.float64) * theirs.rotations).sum(1))).max() <= 4 * EPS32
    assert np.abs(o.opacities - theirs.opacities).max() <= 4 * EPS32
    assert np.abs(o.sh_dc - theirs.sh_dc).max() <= 8 * EPS32 * max(1.0, float(np.abs(o.sh_dc).max()))
    if o.sh_degree:
        assert np.abs(o.sh_rest - theirs.sh_rest).max() <= 8 * EPS32 * max(1.0, float(np.abs(o.sh_rest).max()))


@needs_peer
@pytest.mark.parametrize("sh", [True, False], ids=["quality_sh", "portable"])
def test_lcc_equals_splat_transforms_decode(tmp_path, sh):
    path = write_lcc(tmp_path / ("sh" if sh else "nosh"), _lods(), sh=sh)
    _same_as_peer(read(path), _peer_decode(path, tmp_path))
    _same_as_peer(read(path, lod=2), _peer_decode(path, tmp_path, lod=2))


@needs_peer
@pytest.mark.parametrize("kind", LCC2_KINDS)
def test_lcc2_equals_splat_transforms_decode(tmp_path, kind):
    path = write_lcc2(tmp_path / "s", _lods(), env=random_splats(7, 3, seed=5), **kind)
    _same_as_peer(read(path), _peer_decode(path, tmp_path))
    _same_as_peer(read(path, lod=1), _peer_decode(path, tmp_path, lod=1))


# --- bad scenes ---------------------------------------------------------------------------

def _fails(path, named, *words, **opts):
    """One SplatFormatError, one line, naming `named` (the file at fault) and the words."""
    with pytest.raises(SplatFormatError) as info:
        read(path, **opts)
    msg = str(info.value)
    assert "\n" not in msg and str(named) in msg, msg
    for w in words:
        assert w in msg, msg
    return msg


@pytest.fixture
def lcc(tmp_path):
    return write_lcc(tmp_path / "s", _lods())


def _edit_meta(path, **fields):
    meta = json.loads(open(path).read())
    for k, v in fields.items():
        if v is None:
            meta.pop(k, None)
        else:
            meta[k] = v
    open(path, "w").write(json.dumps(meta))


@pytest.mark.parametrize("missing", ["data.bin", "index.bin", "shcoef.bin"])
def test_missing_sibling_file(lcc, missing):
    target = os.path.join(os.path.dirname(lcc), missing)
    os.remove(target)
    _fails(lcc, target, "no such file")


@pytest.mark.parametrize("fields, words", [
    (dict(version="6.0"), ("unknown LCC version '6.0'",)),
    (dict(version="beta"), ("not a version number",)),
    (dict(encoding="RAW"), ("unknown LCC encoding 'RAW'",)),
    (dict(totalLevel=2), ("totalLevel",)),
    (dict(splats=[400, -1, 25]), ("splats",)),
    (dict(splats=[401, 90, 25]), ("hold 400 splats at LOD 0", "meta.lcc says 401")),
    (dict(attributes=[{"name": "shcoef", "min": [0, 0, 0], "max": [1, 1, 1]}]), ("no `scale` attribute",)),
    (dict(attributes=[{"name": "scale", "min": [0, 0], "max": [1, 1, 1]}]), ("3 finite numbers",)),
])
def test_bad_meta(lcc, fields, words):
    _edit_meta(lcc, **fields)
    _fails(lcc, lcc, *words)


def test_not_json_and_not_text(lcc):
    open(lcc, "w").write("{\"splats\": [1,")
    _fails(lcc, lcc, "not JSON")
    open(lcc, "wb").write(b"\xff\xfe\x00junk")
    _fails(lcc, lcc, "not UTF-8")


def test_index_and_data_sizes(lcc):
    folder = os.path.dirname(lcc)
    index, data = os.path.join(folder, "index.bin"), os.path.join(folder, "data.bin")
    raw = open(index, "rb").read()
    open(index, "wb").write(raw[:-3])
    _fails(lcc, index, "not a whole number of 52-byte units")
    open(index, "wb").write(raw)
    with open(data, "r+b") as f:  # data.bin cut short: the last block runs past its end
        f.truncate(os.path.getsize(data) - 32)
    _fails(lcc, data, "past the end of the file", lod=2)  # the last block is unit 2's LOD 2
    units = np.frombuffer(raw, np.uint8).copy()
    units[4 + 4:4 + 12] = np.frombuffer(np.array([1 << 50], "<i8").tobytes(), np.uint8)  # unit 0 LOD 0 offset
    open(index, "wb").write(units.tobytes())
    _fails(lcc, data, "past the end of the file")
    units[4:8] = np.frombuffer(np.array([-5], "<i4").tobytes(), np.uint8)
    open(index, "wb").write(units.tobytes())
    _fails(lcc, index, "negative")


def test_budget_refuses_before_any_data_file_is_opened(lcc):
    os.remove(os.path.join(os.path.dirname(lcc), "data.bin"))
    _fails(lcc, lcc, "more than the splat budget", max_splats=100)


@pytest.fixture
def lcc2(tmp_path):
    return write_lcc2(tmp_path / "t", _lods(0), splat_type=".spz")


def _edit_lcc2(path, edit):
    meta = json.loads(open(path).read())
    edit(meta)
    open(path, "w").write(json.dumps(meta))


def test_lcc2_bad_scenes(lcc2):
    folder = os.path.dirname(lcc2)
    good = open(lcc2).read()
    _edit_lcc2(lcc2, lambda m: m.update(splatType=".ply"))
    _fails(lcc2, lcc2, "unknown LCC2 splatType '.ply'")
    open(lcc2, "w").write(good)
    _edit_lcc2(lcc2, lambda m: m["root"].update(splatFiles=m["root"]["splatFiles"][:2]))
    _fails(lcc2, lcc2, "names chunk", "lists 2 files")
    open(lcc2, "w").write(good)
    _edit_lcc2(lcc2, lambda m: m["root"]["splatFiles"].__setitem__(-1, "../../etc/x.spz"))
    _fails(lcc2, lcc2, "not a path inside its folder")
    open(lcc2, "w").write(good)
    _edit_lcc2(lcc2, lambda m: m.pop("totalLevels"))
    _fails(lcc2, lcc2, "LOD count")
    open(lcc2, "w").write(good)
    chunk = json.loads(good)["root"]["splatFiles"][-1]
    os.remove(os.path.join(folder, chunk))
    _fails(lcc2, lcc2, f"chunk file {chunk!r} is missing")
    shutil.copy(os.path.join(folder, json.loads(good)["root"]["splatFiles"][0]), os.path.join(folder, chunk))
    _fails(lcc2, os.path.join(folder, chunk), "meta.lcc2 says")  # another chunk's count


@pytest.mark.parametrize("degree", [0, 3])
def test_read_peak_stays_within_the_budgets_estimate(tmp_path, degree):
    """check_budget admits a scene by _common.splat_bytes (256 bytes a splat + 8 a higher-SH
    float): the read's Python peak (numpy's arrays included) must not exceed it."""
    from addon.core.formats._common import splat_bytes
    from bench.formats_bench import peak_bytes

    n = 60_000
    path = write_lcc(tmp_path / "s", [random_splats(n, degree, seed=1, dc=0.5)], sh=degree > 0, units=8)
    peak = peak_bytes(lambda: read(path))
    assert peak <= splat_bytes(n, 45 if degree else 0), peak / n
