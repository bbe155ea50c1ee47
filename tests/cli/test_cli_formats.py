"""python -m addon info / convert, run as a user runs them (a real subprocess)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from addon.core.errors import SplatFormatError
from addon.core.formats import read
from addon.core.formats.ply import write_ply
from testing.synth import random_splats
from testing.cli_runs import cli

READABLE = ["guitar.ply", "guitar.compressed.ply", "guitar.splat", "guitar.spz", "guitar_v3.spz"]


@pytest.mark.parametrize("name", READABLE + ["test64.compressed.ply"])
def test_info_json(testdata, name):
    r = cli("info", testdata / name, "--json")
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    s = read(testdata / name)
    assert info["count"] == s.count and info["sh_degree"] == s.sh_degree
    assert info["format"] == ("compressed_ply" if "compressed" in name else name.split(".")[-1])
    assert info["axes"] == s.axes == ("RUB" if name.endswith(".spz") else "RDF")  # SPZ's own frame
    np.testing.assert_array_equal(info["bbox_min"], s.positions.min(axis=0))
    np.testing.assert_array_equal(info["bbox_max"], s.positions.max(axis=0))
    assert info["bad_values"]["nonfinite"] == 0


def test_info_takes_the_axes_override(testdata):
    """--axes as import, convert and render take it: splat-transform 3.7's .spz holds the
    PLY's frame; the bounds are the file's values either way."""
    plain = json.loads(cli("info", testdata / "test64.spz", "--json").stdout)
    r = cli("info", testdata / "test64.spz", "--json", "--axes", "RDF")
    assert r.returncode == 0, r.stderr
    said = json.loads(r.stdout)
    assert (plain["axes"], said["axes"]) == ("RUB", "RDF") and said["bbox_min"] == plain["bbox_min"]


def test_info_table(testdata):
    r = cli("info", testdata / "test64.spz")
    assert r.returncode == 0
    assert "64" in r.stdout and "SH degree" in r.stdout and "spz" in r.stdout


def test_info_reports_bad_values(tmp_path):
    s = random_splats(8, 0, seed=1)
    s.positions[2, 1] = np.nan
    s.rotations[5] = 0
    write_ply(tmp_path / "b.ply", s)
    info = json.loads(cli("info", tmp_path / "b.ply", "--json").stdout)
    assert info["bad_values"]["nonfinite"] == 1 and info["bad_values"]["zero_quaternions"] == 1
    assert all(np.isfinite(info["bbox_min"]))


@pytest.mark.parametrize("name", READABLE)
@pytest.mark.parametrize("out_ext", [".ply", ".splat"])
def test_convert_every_pair(testdata, tmp_path, name, out_ext):
    out = tmp_path / f"out{out_ext}"
    # splat-transform 3.7 wrote these .spz in the PLY's frame: said with --axes RDF, the
    # values go through unturned (without it they are turned from SPZ's RUB)
    axes = ("--axes", "RDF") if name.endswith(".spz") else ()
    r = cli("convert", testdata / name, out, *axes)
    assert r.returncode == 0, r.stderr
    src, got = read(testdata / name, axes=axes[-1] if axes else None), read(out)
    assert got.count == src.count == 90854
    if out_ext == ".ply":  # float PLY holds what was read: opacity within 1 ulp of 1.0
        np.testing.assert_array_equal(got.positions, src.positions)
        np.testing.assert_allclose(got.opacities, src.opacities, rtol=0, atol=np.finfo(np.float32).eps)
    else:  # .splat re-quantizes colour/alpha to u8 (rounded): half a step
        assert np.abs(got.opacities - src.opacities).max() <= 0.5 / 255 + 1e-7


def test_convert_options(testdata, tmp_path):
    out = tmp_path / "small.ply"
    r = cli("convert", testdata / "test64.ply", out, "--max-sh-degree", "1", "--min-opacity", "0.2",
            "--max-count", "10")
    assert r.returncode == 0, r.stderr
    s, src = read(out), read(testdata / "test64.ply")
    assert s.sh_degree == 1 and s.count == min(10, int((src.opacities >= 0.2).sum()))
    assert (s.opacities >= 0.2 - 1e-7).all()


@pytest.mark.parametrize("args,word", [
    (("info", "{tmp}/missing.ply"), "no such file"),
    (("info", "{tmp}"), "directory"),
    (("convert", "{data}/test64.ply", "{tmp}/x.obj"), "cannot write"),  # .obj: no splat writer
    (("convert", "{tmp}/trunc.ply", "{tmp}/x.ply"), "truncated"),
])
def test_errors_are_one_line(testdata, tmp_path, args, word):
    (tmp_path / "trunc.ply").write_bytes((testdata / "test64.ply").read_bytes()[:-50])
    r = cli(*[a.format(tmp=tmp_path, data=testdata) for a in args])
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and word in lines[0] and "Traceback" not in r.stderr, r.stderr


INRIA_PROPS = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", "opacity",
               "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]


def empty_ply(path):
    """A valid INRIA 3DGS .ply with 0 vertices (header only), written by hand."""
    header = ["ply", "format binary_little_endian 1.0", "element vertex 0"]
    header += [f"property float {p}" for p in INRIA_PROPS] + ["end_header", ""]
    path.write_bytes("\n".join(header).encode("ascii"))
    return path


def one_error_line(r) -> str:
    assert r.returncode == 1, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), r.stderr
    return lines[0]


@pytest.mark.parametrize("out_ext", [".splat", ".ply"])
def test_convert_refuses_zero_splats(tmp_path, out_ext):
    src, out = empty_ply(tmp_path / "empty.ply"), tmp_path / f"out{out_ext}"
    line = one_error_line(cli("convert", src, out))
    assert str(src) in line and "holds no splats" in line
    assert not out.exists()


def test_convert_refuses_when_the_options_leave_no_splats(testdata, tmp_path):
    out = tmp_path / "out.splat"  # a 0-splat .splat is a 0-byte file the reader rejects
    line = one_error_line(cli("convert", testdata / "test64.ply", out, "--keep-where", "opacity>2"))
    assert str(testdata / "test64.ply") in line and "no splats left" in line
    assert not out.exists()


def test_info_on_zero_splats_still_answers(tmp_path):
    """0 is a legitimate answer for info (only convert and import refuse an empty file)."""
    src = empty_ply(tmp_path / "empty.ply")
    r = cli("info", src, "--json")
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    assert info["count"] == 0 and info["bbox_min"] is None and info["format"] == "ply"
    r = cli("info", src)
    assert r.returncode == 0 and "splats" in r.stdout and "Traceback" not in r.stderr, r.stderr


def unreadable_file():
    """A regular, non-empty file that open() refuses even to root: a write-only sysfs attribute
    (kernfs answers EACCES to a read open when the attribute has no read method)."""
    for path in ("/sys/bus/pci/drivers_probe", "/sys/bus/pci/rescan", "/sys/kernel/uevent_helper"):
        try:
            with open(path, "rb"):
                continue  # readable here: no use
        except PermissionError:
            return path
        except OSError:
            continue
    pytest.skip("no write-only sysfs file to provoke PermissionError with")


def test_read_permission_error_is_a_splat_format_error():
    """The formats contract: every reader failure is SplatFormatError naming the file."""
    path = unreadable_file()
    with pytest.raises(SplatFormatError, match="Permission denied") as exc:
        read(path)
    assert exc.value.path == path


@pytest.mark.parametrize("args,name", [
    (("info", "{unreadable}"), "{unreadable}"),  # PermissionError from open()
    (("convert", "{data}/test64.ply", "{tmp}/file/out.ply"), "{tmp}/file/out.ply"),  # parent is a file
    (("render", "{tmp}/file", "--out", "{tmp}/file/frames"), "{tmp}/file/frames"),  # os.makedirs
])
def test_os_errors_are_one_line(testdata, tmp_path, args, name):
    (tmp_path / "file").write_bytes(b"a regular file, so nothing can be created under it")
    fill = dict(tmp=tmp_path, data=testdata,
                unreadable=unreadable_file() if "{unreadable}" in args[1] else "")
    line = one_error_line(cli(*[a.format(**fill) for a in args]))
    assert name.format(**fill) in line and "Errno" not in line, line
    assert not (tmp_path / "file" / "out.ply").exists()


def test_memory_error_is_one_line(monkeypatch, capsys):
    """No honest way to run out of memory in a test: the command itself raises it."""
    from addon.__main__ import main
    from addon.cli import info

    def out_of_memory(args):
        raise MemoryError
    monkeypatch.setattr(info, "run", out_of_memory)
    assert main(["info", "whatever.ply"]) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "out of memory" in lines[0], lines


def test_info_shows_the_antialiased_mark(testdata, tmp_path):
    from dataclasses import replace

    from addon.core.formats import write

    write(tmp_path / "aa.spz", replace(read(testdata / "test64.ply"), antialiased=True))
    assert json.loads(cli("info", tmp_path / "aa.spz", "--json").stdout)["antialiased"] is True
    assert json.loads(cli("info", testdata / "test64.ply", "--json").stdout)["antialiased"] is False
    assert "anti-aliased         yes" in cli("info", tmp_path / "aa.spz").stdout
