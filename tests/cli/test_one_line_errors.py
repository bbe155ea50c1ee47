"""Every bad input or option is one clear line (`error: WHAT: WHY`, exit 1 for
data, 2 for usage) and nothing is allocated past the memory budget (core/budget.py): the
child's peak RSS is measured under `--max-memory 1.5G` for each hostile file and option."""
from __future__ import annotations

import gzip
import json
import os
import shutil
import struct
from pathlib import Path

import numpy as np
import pytest
from testing.measured_cli import cli, one_line

BUDGET = "1.5G"
PEAK_LIMIT = int(1.5 * 2**30)

# Runs the CLI as its own child, so RUSAGE_CHILDREN is that one command's peak alone
# (pytest's own RUSAGE_CHILDREN keeps the largest child any earlier test ran).
# --- hostile files ----------------------------------------------------------------------

def _sog_folder(testdata, tmp_path, edit):
    folder = tmp_path / "sog"
    shutil.copytree(testdata / "test64_sog_unbundled", folder)
    meta = json.loads((folder / "meta.json").read_text())
    edit(meta)
    (folder / "meta.json").write_text(json.dumps(meta))
    return folder / "meta.json"


def _glb_chunks(path):
    data = Path(path).read_bytes()
    n = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + n])
    rest = data[20 + n:]
    blen = struct.unpack_from("<I", rest, 0)[0]
    return doc, rest[8:8 + blen]


def _glb(path, doc, binary):
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(binary), 0x004E4942) + binary
    Path(path).write_bytes(struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body)


def test_nul_byte_in_a_sog_file_name(testdata, tmp_path):
    def edit(meta):
        meta["means"]["files"][0] = "means\0_l.webp"
    meta = _sog_folder(testdata, tmp_path, edit)
    rc, _, err, _ = cli("info", meta)
    assert rc == 1
    one_line(err, str(meta), "plain file name")


def test_nul_byte_in_a_gltf_uri(testdata, tmp_path):
    doc, binary = _glb_chunks(testdata / "test64.glb")
    (tmp_path / "x.bin").write_bytes(binary)
    doc["buffers"][0]["uri"] = "x\0.bin"
    gltf = tmp_path / "nul.gltf"
    gltf.write_text(json.dumps(doc))
    rc, _, err, _ = cli("info", gltf)
    assert rc == 1
    one_line(err, str(gltf), "nul")


def test_encrypted_sog_zip(testdata, tmp_path):
    data = bytearray((testdata / "test64.sog").read_bytes())
    for sig, flag_at in ((b"PK\x03\x04", 6), (b"PK\x01\x02", 8)):  # set "encrypted" everywhere
        at = data.find(sig)
        while at >= 0:
            data[at + flag_at] |= 1
            at = data.find(sig, at + 4)
    sog = tmp_path / "encrypted.sog"
    sog.write_bytes(bytes(data))
    rc, _, err, _ = cli("info", sog)
    assert rc == 1
    one_line(err, str(sog), "encrypted")


def _spz_of_zeros(path, count=10_000_000):
    """A gzip'd SPZ v2 of zeros claiming `count` splats: ~185 KB on disk, GBs decoded."""
    header = struct.pack("<IIIBBBB", 0x5053474E, 2, count, 0, 12, 0, 0)
    per = 9 + 1 + 3 + 3 + 3  # positions, alpha, colour, scale, rotation
    with gzip.open(path, "wb", compresslevel=9) as f:
        f.write(header)
        zeros = bytes(per * 1_000_000)
        for _ in range(count // 1_000_000):
            f.write(zeros)


def test_spz_claiming_ten_million_splats_is_refused_within_the_budget(tmp_path):
    spz = tmp_path / "zeros.spz"
    _spz_of_zeros(spz)
    assert spz.stat().st_size < 400_000
    rc, _, err, peak = cli("info", spz, "--max-memory", BUDGET)
    assert rc == 1
    line = one_line(err, str(spz), "10000000 splats", "--max-memory")
    assert "budget" in line
    assert peak < PEAK_LIMIT, peak
    print(f"spz of zeros, 10M splats: peak RSS {peak / 2**20:.0f} MiB")


def test_ksplat_claiming_a_hundred_million_splats_is_refused_within_the_budget(tmp_path):
    """A level-0 .ksplat whose one section holds 100M splats: the file is as long as they need
    (sparse, so the test writes 5 KB), and the claim is refused before any record is read."""
    n = 100_000_000
    head = np.zeros(4096 + 1024, np.uint8)
    u32 = head.view("<u4")
    head[1] = 1  # version 0.1
    u32[1] = u32[2] = 1  # one section
    u32[3] = u32[4] = n
    u32[1024] = u32[1025] = n  # the section's splats and slots; level 0, SH degree 0
    path = tmp_path / "huge.ksplat"
    with open(path, "wb") as f:
        f.write(head.tobytes())
        f.truncate(head.size + 44 * n)
    rc, _, err, peak = cli("info", path, "--max-memory", BUDGET)
    assert rc == 1
    line = one_line(err, str(path), f"{n} splats", "--max-memory")
    assert "budget" in line
    assert peak < PEAK_LIMIT, peak


def _reused_glb(tmp_path):
    """65,536 splats of SH degree 3, and 128 primitives reusing their one accessor set."""
    from addon.core.formats import write
    from testing.synth import random_splats

    base = tmp_path / "base.glb"
    write(base, random_splats(65536, degree=3, seed=2), "glb")
    doc, binary = _glb_chunks(base)
    base.unlink()
    prims = doc["meshes"][0]["primitives"]
    doc["meshes"][0]["primitives"] = [dict(prims[0]) for _ in range(128)]
    hostile = tmp_path / "reused.glb"
    _glb(hostile, doc, binary)
    assert hostile.stat().st_size < 16 * 2**20
    return hostile


def test_glb_reusing_accessors_counts_every_use(tmp_path):
    hostile = _reused_glb(tmp_path)
    rc, _, err, peak = cli("info", hostile, "--max-memory", BUDGET)
    assert rc == 1
    one_line(err, str(hostile), "8388608 splats", "--max-memory")
    assert peak < PEAK_LIMIT, peak
    print(f"glb, 128 primitives reusing one accessor set: peak RSS {peak / 2**20:.0f} MiB")


def test_import_of_reused_accessors_is_refused_before_blender_holds_them(tmp_path):
    """The same .glb through `import --blend`: refused by the reader's budget in one line,
    no .blend written, the peak (bpy started) under the budget."""
    hostile = _reused_glb(tmp_path)
    blend = tmp_path / "x.blend"
    rc, _, err, peak = cli("import", hostile, "--blend", blend, "--max-memory", BUDGET)
    assert rc == 1
    one_line(err, str(hostile), "8388608 splats", "--max-memory")
    assert sorted(os.listdir(tmp_path)) == ["reused.glb"]
    assert peak < PEAK_LIMIT, peak
    print(f"import of the reused-accessor glb: peak RSS {peak / 2**20:.0f} MiB")


def test_sog_claiming_a_quarter_billion_splats_is_refused_within_the_budget(testdata, tmp_path):
    def edit(meta):
        meta["count"] = 268_000_000  # about WebP's 16383 x 16383 ceiling
    meta = _sog_folder(testdata, tmp_path, edit)
    rc, _, err, peak = cli("info", meta, "--max-memory", BUDGET)
    assert rc == 1
    one_line(err, str(meta), "268000000")
    assert peak < PEAK_LIMIT, peak
    print(f"SOG claiming 268M splats: peak RSS {peak / 2**20:.0f} MiB")


def test_sog_image_of_huge_dimensions_is_refused_before_decoding(testdata, tmp_path):
    """A 2.6 KB lossless WebP of 8192 x 8192 (256 MiB decoded) as a 64-splat SOG's means:
    refused from its header, the peak well under what decoding it would take."""
    from addon.core.formats.webp import write_rgba

    if not _webp_ok():
        pytest.skip("this OpenImageIO cannot write WebP")
    meta = _sog_folder(testdata, tmp_path, lambda meta: None)
    pixels = np.zeros((8192, 8192, 4), np.uint8)
    write_rgba(meta.parent / "means_l.webp", pixels)
    del pixels
    assert (meta.parent / "means_l.webp").stat().st_size < 64 * 1024
    rc, _, err, peak = cli("info", meta, "--max-memory", BUDGET)
    assert rc == 1
    one_line(err, "means_l.webp", "8192x8192")
    assert peak < 8192 * 8192 * 4, peak
    print(f"SOG image claiming 8192x8192: peak RSS {peak / 2**20:.0f} MiB")


def test_lcc_claiming_billions_of_splats_is_refused_within_the_budget(tmp_path):
    """An LCC scene whose index.bin claims 100 units of 67M splats (the most a block's i32
    size allows), its data.bin 32 bytes: refused from meta.lcc and index.bin before data.bin
    is opened, in one line naming the meta file."""
    from testing.lcc_files import write_lcc
    from testing.synth import random_splats

    meta = write_lcc(tmp_path / "lcc", [random_splats(1, 0)], sh=False, units=1)
    per_unit = (2**31 - 1) // 32
    unit = struct.pack("<hhiqi", 0, 0, per_unit, 0, per_unit * 32)
    (tmp_path / "lcc" / "index.bin").write_bytes(unit * 100)
    doc = json.loads(Path(meta).read_text())
    doc["splats"] = [per_unit * 100]
    Path(meta).write_text(json.dumps(doc))
    rc, _, err, peak = cli("info", meta, "--max-memory", BUDGET)
    assert rc == 1
    one_line(err, meta, f"{per_unit * 100} splats", "--max-memory")
    assert peak < PEAK_LIMIT, peak
    print(f"LCC claiming {per_unit * 100} splats: peak RSS {peak / 2**20:.0f} MiB")


def _webp_ok():
    try:
        from addon.core.formats.webp import keeps_straight_alpha
        return keeps_straight_alpha()
    except Exception:
        return False


# --- render options ---------------------------------------------------------------------

def test_render_resolution_16384_is_refused_within_the_budget(testdata, tmp_path):
    out = tmp_path / "out"
    rc, _, err, peak = cli("render", testdata / "test64.ply", "--out", out, "--frames", "1",
                           "--resolution", "16384x16384", "--max-memory", BUDGET)
    assert rc == 1
    one_line(err, "--resolution 16384x16384", "GiB", "--max-memory")
    assert not out.exists()
    assert peak < PEAK_LIMIT, peak
    print(f"render --resolution 16384x16384: peak RSS {peak / 2**20:.0f} MiB")


def test_render_resolution_65536_is_one_line(testdata, tmp_path):
    out = tmp_path / "out"
    rc, _, err, _ = cli("render", testdata / "test64.ply", "--out", out, "--frames", "1",
                        "--resolution", "65536x65536")
    assert rc == 1
    one_line(err, "--resolution 65536x65536", "--max-memory")
    assert not out.exists()


@pytest.mark.parametrize("args, words", [
    (("--frames", "99999999999"), ("--frames 99999999999", "1048574")),
    (("--frames", "2000000"), ("--frames 2000000", "1048574")),  # was clamped to 1048574
    (("--frames", "1", "--resolution", "70000x100"), ("--resolution 70000x100", "65536")),  # was clamped
    (("--frames", "1", "--resolution", "2x2"), ("--resolution 2x2", "4-65536")),  # was clamped to 4
])
def test_render_limits_are_usage_errors_not_clamps(testdata, tmp_path, args, words):
    out = tmp_path / "out"
    rc, _, err, _ = cli("render", testdata / "test64.ply", "--out", out, *args, timeout=60)
    assert rc == 2
    one_line(err, *words)
    assert not out.exists()


def test_render_limits_match_blender(bpy_empty):
    import bpy
    from addon.cli import render

    scene = bpy.types.Scene.bl_rna.properties
    settings = bpy.types.RenderSettings.bl_rna.properties
    for name in ("frame_start", "frame_end"):
        assert (scene[name].hard_min, scene[name].hard_max) == (0, render.MAX_FRAME)
    for name in ("resolution_x", "resolution_y"):
        assert (settings[name].hard_min, settings[name].hard_max) == (render.MIN_RESOLUTION,
                                                                       render.MAX_RESOLUTION)


def test_rejected_option_leaves_no_out_folder(testdata, tmp_path):
    out = tmp_path / "out"
    rc, _, err, _ = cli("render", testdata / "test64.ply", "--out", out, "--frames", "1",
                        "--engine-option", "bogus=1")
    assert rc == 2  # a usage error
    one_line(err, "--engine-option")
    assert not out.exists()


def _unwritable(tmp_path):
    """A folder this process cannot make files in, root included: /proc/1 (Linux)."""
    if not os.path.isdir("/proc/1"):
        pytest.skip("no /proc")
    return "/proc/1"


def test_render_into_an_unwritable_folder(testdata, tmp_path):
    folder = _unwritable(tmp_path)
    rc, _, err, _ = cli("render", testdata / "test64.ply", "--out", folder, "--frames", "1", timeout=60)
    assert rc == 1
    one_line(err, folder, "cannot write")


def test_unbundled_sog_into_a_missing_or_unwritable_folder(testdata, tmp_path):
    missing = tmp_path / "missing" / "meta.json"
    rc, _, err, _ = cli("convert", testdata / "test64.ply", missing)
    assert rc == 1
    one_line(err, str(missing.parent), "no such folder")
    folder = _unwritable(tmp_path)
    rc, _, err, _ = cli("convert", testdata / "test64.ply", os.path.join(folder, "meta.json"))
    assert rc == 1
    one_line(err, folder, "cannot write")


def test_budget_parses_sizes_and_names_the_flag():
    from addon.core import budget
    from addon.core.errors import SplatFormatError

    assert budget.parse_size("1.5G") == int(1.5 * 2**30)
    assert budget.parse_size("800M") == 800 * 2**20
    assert budget.parse_size("2GiB") == 2 * 2**30
    assert budget.parse_size("4096") == 4096
    for bad in ("", "G", "-1G", "0", "1.5X"):
        with pytest.raises(ValueError):
            budget.parse_size(bad)
    budget.set_max_memory(1 << 20)
    try:
        with pytest.raises(SplatFormatError, match="--max-memory"):
            budget.check("thing", 1 << 40, "--max-memory")
    finally:
        budget.set_max_memory(None)


def test_bad_max_memory_is_a_usage_error(testdata):
    rc, _, err, _ = cli("info", testdata / "test64.ply", "--max-memory", "lots")
    assert rc == 2
    assert "--max-memory" in err and "Traceback" not in err


def test_numpy_overflow_warnings_stay_off_stderr(tmp_path):
    """Huge log-scales and logits overflow exp in decoding: the bad-value report is the one
    line, never numpy's RuntimeWarning (it reached stderr before)."""
    from addon.core.formats.ply import write_ply
    from testing.synth import random_splats

    base = tmp_path / "base.ply"
    write_ply(base, random_splats(16, seed=1))
    data = base.read_bytes()
    body = data.index(b"end_header\n") + len(b"end_header\n")
    names = [ln.split()[-1] for ln in data[:body].decode().splitlines() if ln.startswith("property")]
    records = np.frombuffer(data[body:], dtype=[(n, "<f4") for n in names]).copy()
    records["scale_0"][:4] = 1000.0  # exp overflows
    records["opacity"][:4] = -1e30  # the sigmoid's exp overflows
    hostile = tmp_path / "overflow.ply"
    hostile.write_bytes(data[:body] + records.tobytes())
    rc, _, err, _ = cli("info", hostile)
    assert rc == 0 and "Warning" not in err, err
    rc, _, err, _ = cli("convert", hostile, tmp_path / "out.spz")
    assert rc == 0, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert "Warning" not in err and lines[0].startswith("warning: ") and "NaN/Inf" in lines[0], err
    # the bad-value report, then only the writer's own notes (the .spz scale clamp of the
    # neutralised splats, formats.write's notes): no numpy line
    assert all(ln.startswith(f"warning: {tmp_path / 'out.spz'}: ") for ln in lines[1:]), err


def test_misspelled_option_gives_the_sub_command_usage(testdata, tmp_path):
    rc, _, err, _ = cli("render", testdata / "test64.ply", "--out", tmp_path / "o", "--otu", "x",
                        timeout=60)
    assert rc == 2
    assert "usage: python -m addon render" in err, err
    assert "unrecognized arguments: --otu x (did you mean --out?)" in err, err
    assert not (tmp_path / "o").exists()


def test_an_ordinary_render_fits_the_budget(testdata, tmp_path):
    """The budget refuses what would pass it, not ordinary work: Blender, the capture and a
    small frame stay under --max-memory 1.5G, measured."""
    out = tmp_path / "out"
    rc, _, err, peak = cli("render", testdata / "test64.ply", "--out", out, "--frames", "1",
                           "--resolution", "64x64", "--max-memory", BUDGET)
    assert rc == 0, err
    assert (out / "frame_0001.png").is_file()
    assert peak < PEAK_LIMIT, peak
    print(f"render test64.ply 64x64 under --max-memory {BUDGET}: peak RSS {peak / 2**20:.0f} MiB")


@pytest.mark.parametrize("args, rc_want, words", [
    (("--frames", "99999999999"), 2, ("--frames 99999999999", "1048574")),  # was a traceback
    (("--splats", "100000000", "--max-memory", BUDGET), 1, ("--splats 100000000", "--max-memory")),
    (("--resolution", "16384x16384", "--max-memory", BUDGET), 1, ("--resolution 16384x16384", "--max-memory")),
])
def test_demo_options_are_one_line_within_the_budget(tmp_path, args, rc_want, words):
    out = tmp_path / "demo"
    rc, _, err, peak = cli("demo", "--out", out, *args, timeout=60)
    assert rc == rc_want
    one_line(err, *words)
    assert not out.exists()
    assert peak < PEAK_LIMIT, peak


@pytest.mark.parametrize("command", ["convert", "import", "render", "demo"])
def test_every_command_checks_its_output_folder_before_its_input(testdata, tmp_path, command):
    """Issue 42: `import` into a read-only folder read the whole file first, then failed in
    two lines showing Blender's `x.blend@`. The input here is broken too: the folder is what
    each command must name, so it was checked first (one line, exit 1)."""
    folder = _unwritable(tmp_path)
    broken = tmp_path / "broken.ply"
    broken.write_bytes((testdata / "test64.ply").read_bytes()[:-50])
    args = {"convert": ("convert", broken, os.path.join(folder, "o.ply")),
            "import": ("import", broken, "--blend", os.path.join(folder, "x.blend")),
            "render": ("render", broken, "--out", os.path.join(folder, "frames")),
            "demo": ("demo", "--file", broken, "--out", os.path.join(folder, "demo"))}[command]
    rc, _, err, _ = cli(*args, timeout=60)
    assert rc == 1
    one_line(err, folder, "cannot write")
    assert "truncated" not in err and "@" not in err
