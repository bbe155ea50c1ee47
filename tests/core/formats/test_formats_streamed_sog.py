"""Streamed SOG (lod-meta.json, formats/streamed_sog.py) against the peer that writes it:
splat-transform 3.7's LOD writer makes the files at test time from PLY levels Splatline
writes, and every level Splatline reads must be the splats splat-transform decodes for that
level (`-L N` to a float PLY), index for index, within the two decoders' float rounding.
Bad manifests and chunks are one SplatFormatError naming the file, and leave nothing behind.

Peer tests: they skip without splat-transform, naming where it is looked for, and fail under
CI (testing/streamed_sog_files.peer_or_skip)."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from addon.core import budget
from addon.core.errors import SplatFormatError
from addon.core.formats import detect_format, read, read_with_report
from addon.core.formats._common import splat_bytes
from bench.formats_bench import run_splat_transform
from testing.cli_runs import cli
from testing.streamed_sog_files import levels_of, make_streamed_sog, peer_or_skip
from testing.webp_support import STRAIGHT_WEBP

pytestmark = pytest.mark.skipif(not STRAIGHT_WEBP, reason="this OpenImageIO premultiplies WebP "
                                "alpha (Blender 4.5): SOG is refused here")
EPS32 = float(np.finfo(np.float32).eps)
STRIDES = (1, 4, 16)  # level 0 every splat, then every 4th, every 16th


@pytest.fixture(scope="module")
def guitar_lod(testdata, tmp_path_factory):
    """20,000 guitar splats (SH 0) at three levels: several chunks at level 0."""
    cmd = peer_or_skip()
    levels = levels_of(read(testdata / "guitar.ply"), STRIDES, 20000)
    return make_streamed_sog(cmd, tmp_path_factory.mktemp("guitar_lod"), levels), [s.count for s in levels]


@pytest.fixture(scope="module")
def sh_lod(testdata, tmp_path_factory):
    """test64 (SH degree 3) at two levels: palettes in every chunk."""
    cmd = peer_or_skip()
    levels = levels_of(read(testdata / "test64.ply"), (1, 4))
    return make_streamed_sog(cmd, tmp_path_factory.mktemp("sh_lod"), levels), [s.count for s in levels]


def _compare(ours, theirs) -> None:
    """Same splats in the same order, within float rounding of the two decoders."""
    assert theirs.count == ours.count > 0 and theirs.sh_degree == ours.sh_degree
    extent = float(np.abs(ours.positions).max())
    assert np.abs(theirs.positions - ours.positions).max() <= 8 * EPS32 * extent
    log_s = np.log(ours.scales.astype(np.float64))
    assert (np.abs(np.log(theirs.scales.astype(np.float64)) - log_s) <= 16 * EPS32 * np.maximum(1, np.abs(log_s))).all()
    # opacity travels as a float32 logit; splat-transform clamps it to [1e-6, 1 - 1e-6] first
    assert np.abs(theirs.opacities - ours.opacities).max() <= 1e-6 + 8 * EPS32
    for name in ("sh_dc", "sh_rest"):
        a, b = getattr(ours, name), getattr(theirs, name)
        assert (np.abs(a - b) <= 8 * EPS32 * np.maximum(1, np.abs(a))).all(), name
    dot = np.abs(np.einsum("ij,ij->i", ours.rotations.astype(np.float64), theirs.rotations))
    assert (dot >= 1 - 1e-6).all(), f"least |dot| {dot.min()}"


@pytest.mark.parametrize("which", ["guitar_lod", "sh_lod"])
def test_each_level_reads_as_splat_transform_decodes_it(request, tmp_path, which):
    path, counts = request.getfixturevalue(which)
    assert detect_format(path) == "streamed_sog"
    assert len(json.loads(path.read_text())["filenames"]) > len(counts) or which == "sh_lod"
    for lod, count in enumerate(counts):
        splats, report = read_with_report(path, lod=lod)
        assert (report.levels, report.level, splats.count) == (counts, lod, count)
        peer = tmp_path / f"peer{lod}.ply"
        run_splat_transform(peer_or_skip(), "-L", lod, path, peer)
        _compare(splats, read(peer))
    assert read(path).count == counts[0]  # the finest by default


def test_levels_hold_their_input_splats(guitar_lod):
    """Against the PLY each level was made from: the same count, and every splat within the
    SOG position quantisation of the level's box (16 bits per axis in log space)."""
    path, counts = guitar_lod
    for lod in range(len(counts)):
        ours, source = read(path, lod=lod), read(path.parent.parent / f"l{lod}.ply")
        assert ours.count == source.count
        lo, hi = source.positions.min(axis=0), source.positions.max(axis=0)
        tol = 1e-3 * float((hi - lo).max())
        np.testing.assert_allclose(ours.positions.min(axis=0), lo, atol=tol)
        np.testing.assert_allclose(ours.positions.max(axis=0), hi, atol=tol)
        # the chunks reorder splats (Morton order), so compare the sorted opacities: 8 bits
        assert np.abs(np.sort(ours.opacities) - np.sort(source.opacities)).max() <= 1 / 255 + 1e-6


def test_cli_info_lists_levels_and_convert_takes_a_level(guitar_lod, tmp_path):
    path, counts = guitar_lod
    run = cli("info", path, "--json")
    assert run.returncode == 0, run.stderr
    info = json.loads(run.stdout)
    assert (info["format"], info["levels"], info["level"], info["count"]) == ("streamed_sog", counts, 0, counts[0])
    table = cli("info", path, "--lod", "2")
    assert table.returncode == 0 and f"splats               {counts[2]:,}" in table.stdout
    assert "level read           2 (--lod N reads another)" in table.stdout
    assert f"0: {counts[0]:,}, 1: {counts[1]:,}, 2: {counts[2]:,}" in table.stdout
    for args, want in (((), counts[0]), (("--lod", "1"), counts[1])):
        out = tmp_path / f"out{len(args)}.ply"
        run = cli("convert", path, out, *args)
        assert run.returncode == 0, run.stderr
        assert read(out).count == want


def test_cli_import_takes_a_level(guitar_lod, tmp_path):
    path, counts = guitar_lod
    out = tmp_path / "out.blend"
    run = cli("import", path, "--lod", "2", "--blend", out, timeout=300)
    assert run.returncode == 0, run.stderr
    assert f"{counts[2]} of {counts[2]} splats" in run.stdout and out.is_file()


def test_a_level_out_of_range_names_the_levels(guitar_lod, tmp_path, testdata):
    path, counts = guitar_lod
    with pytest.raises(SplatFormatError) as err:
        read(path, lod=3)
    assert str(err.value) == (f"{path}: has no level of detail 3; its levels: 0 ({counts[0]:,} splats), "
                              f"1 ({counts[1]:,} splats), 2 ({counts[2]:,} splats)")
    with pytest.raises(SplatFormatError, match="has one level of detail"):
        read(testdata / "test64.ply", lod=1)
    assert read(testdata / "test64.ply", lod=0).count == 64
    out = tmp_path / "x.ply"
    run = cli("convert", path, out, "--lod", "7")
    assert run.returncode == 1 and not out.exists()
    assert run.stderr.strip().count("\n") == 0 and "has no level of detail 7" in run.stderr


def test_over_budget_names_the_level_that_fits(guitar_lod, tmp_path):
    path, counts = guitar_lod
    out = tmp_path / "x.ply"
    run = cli("convert", path, out, "--max-splats", counts[1] + 1)
    assert run.returncode == 1 and not out.exists()
    line = run.stderr.strip()
    assert "\n" not in line and f"level 0 holds {counts[0]} splats" in line
    assert line.endswith(f"level 1 ({counts[1]:,} splats) fits: --lod 1"), line
    # the memory budget: room for level 1 but not level 0 (after_read off: no command's cost)
    budget.after_read(None)
    try:
        budget.set_max_memory(budget.resident() + (splat_bytes(counts[0], 0) + splat_bytes(counts[1], 0)) // 2)
        with pytest.raises(budget.BudgetError) as err:
            read(path)
        assert "more than the memory budget" in str(err.value)
        assert str(err.value).endswith(f"level 1 ({counts[1]:,} splats) fits: --lod 1")
    finally:
        budget.set_max_memory(None)


def _copy(guitar_lod, tmp_path):
    path, _ = guitar_lod
    shutil.copytree(path.parent, tmp_path / "lod")
    return tmp_path / "lod" / "lod-meta.json"


def _edit(path, change) -> None:
    meta = json.loads(path.read_text())
    change(meta)
    path.write_text(json.dumps(meta))


def _first_leaf(meta):
    node = meta["tree"]
    while "children" in node:
        node = node["children"][0]
    return node


@pytest.mark.parametrize("case,want", [
    ("missing_chunk", "no such file (chunk 2 of"),
    ("bad_json", "lod-meta.json is not JSON"),
    ("not_an_object", "lod-meta.json is not a JSON object"),
    ("counts", "counts [1, 2, 3] disagree with its tree"),
    ("escape", "not a relative path inside its folder"),
    ("absolute", "not a relative path inside its folder"),
    ("bad_ref", "bad reference for level '0'"),
    ("chunk_short", "splats, the tree gives it"),
    ("version", "unsupported lod-meta.json version 2"),
    ("levels", "lodLevels must be an integer"),
])
def test_bad_streamed_sogs_are_one_error(guitar_lod, tmp_path, case, want):
    path = _copy(guitar_lod, tmp_path)
    meta = json.loads(path.read_text())
    level0 = sorted({ref["file"] for ref in _leaves_refs(meta, "0")})
    if case == "missing_chunk":
        (path.parent / meta["filenames"][level0[1]]).unlink()
    elif case == "bad_json":
        path.write_text('{"version": 1, "lodLevels": ')
    elif case == "not_an_object":
        path.write_text("[1, 2]")
    elif case == "counts":
        _edit(path, lambda m: m.update(counts=[1, 2, 3]))
    elif case == "escape":
        _edit(path, lambda m: m["filenames"].__setitem__(0, "../elsewhere/meta.json"))
    elif case == "absolute":
        _edit(path, lambda m: m["filenames"].__setitem__(0, "/tmp/meta.json"))
    elif case == "bad_ref":
        _edit(path, lambda m: _first_leaf(m)["lods"]["0"].update(file=99))
    elif case == "chunk_short":  # the tree gives the first chunk fewer splats than it holds
        def shrink(m):
            _first_leaf(m)["lods"]["0"]["count"] -= 1
            m.pop("counts")
        _edit(path, shrink)
    elif case == "version":
        _edit(path, lambda m: m.update(version=2))
    elif case == "levels":
        _edit(path, lambda m: m.update(lodLevels=0))
    with pytest.raises(SplatFormatError) as err:
        read(path)
    assert want in str(err.value)
    out = tmp_path / "x.ply"
    run = cli("convert", path, out)
    assert run.returncode == 1 and not out.exists() and not list(tmp_path.glob("x.ply*"))
    assert run.stderr.strip().count("\n") == 0 and want in run.stderr


def _leaves_refs(meta, lod):
    stack, refs = [meta["tree"]], []
    while stack:
        node = stack.pop()
        stack += node.get("children", [])
        if lod in node.get("lods", {}):
            refs.append(node["lods"][lod])
    return refs
