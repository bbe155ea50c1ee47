"""The format table (core/formats/table.py): each row reads its own real capture, the Blender
operators, FileHandler and the command line offer exactly the rows, and a throwaway format
registered as one row is read, written and offered everywhere, then gone again."""
from __future__ import annotations

import base64
import contextlib
import inspect
import json
import re
import shutil
import struct

import numpy as np
import pytest

from addon.__main__ import _parser, main
from addon.core import formats
from addon.core.errors import SplatFormatError
from addon.core.formats import table
from addon.core.splats import SplatSet
from testing.ksplat_write import write_ksplat
from testing.webp_support import STRAIGHT_WEBP

# Each row's capture in ../shared/testdata; a new row fails test_every_row_has_a_capture
# until it names one. gltf: the test64.glb capture's own document and buffer, unpacked from
# the binary container into a .gltf with an embedded buffer (no .gltf capture is stored).
# ksplat: guitar.ply written at level 2 by testing/ksplat_write.py (no .ksplat is stored).
# streamed_sog: the unbundled test64 SOG as the one chunk of a one-level lod-meta.json (the
# peer's own multi-level files: tests/core/formats/test_formats_streamed_sog.py).
# lcc, lcc2: no scanner's scene is stored (none is public to us); guitar.ply written as one by
# testing/lcc_files.py, to the layout splat-transform reads (a coarser LOD beside it).
CAPTURES = {"ply": "guitar.ply", "compressed_ply": "guitar.compressed.ply", "splat": "guitar.splat",
            "spz": "guitar.spz", "sog": "guitar.sog", "glb": "test64.glb", "gltf": "test64.glb",
            "ksplat": "guitar.ply", "lcc": "guitar.ply", "lcc2": "guitar.ply",
            "streamed_sog": "test64_sog_unbundled"}


def _glb_as_gltf(glb: bytes) -> bytes:
    json_len, = struct.unpack_from("<I", glb, 12)
    doc = json.loads(glb[20:20 + json_len])
    bin_len, = struct.unpack_from("<I", glb, 20 + json_len)
    payload = glb[28 + json_len:28 + json_len + bin_len]
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(payload).decode()
    return json.dumps(doc).encode()


def _capture(name, testdata, tmp_path):
    if name == "ksplat":
        out = tmp_path / "guitar.ksplat"
        write_ksplat(out, formats.read(testdata / CAPTURES[name]), level=2)
        return out
    if name in ("lcc", "lcc2"):
        from testing.lcc_files import write_lcc, write_lcc2
        guitar = formats.read(testdata / CAPTURES[name])
        lods = [guitar, guitar.subset(slice(None, None, 4))]
        return write_lcc(tmp_path / "lcc", lods) if name == "lcc" else write_lcc2(tmp_path / "lcc2", lods)
    if name == "streamed_sog":
        shutil.copytree(testdata / CAPTURES[name], tmp_path / "0_0")
        leaf = {"bound": {"min": [0, 0, 0], "max": [1, 1, 1]}, "lods": {"0": {"file": 0, "offset": 0, "count": 64}}}
        (tmp_path / "lod-meta.json").write_text(json.dumps({"version": 1, "count": 64, "counts": [64], "lodLevels": 1,
                                                            "filenames": ["0_0/meta.json"], "tree": leaf}))
        return tmp_path / "lod-meta.json"
    if name != "gltf":
        return testdata / CAPTURES[name]
    out = tmp_path / "test64.gltf"
    out.write_bytes(_glb_as_gltf((testdata / CAPTURES[name]).read_bytes()))
    return out


def test_every_row_has_a_capture():
    assert set(CAPTURES) == {r.name for r in table.rows()}


@pytest.mark.parametrize("name", [r.name for r in table.rows()])
def test_each_row_reads_its_capture(testdata, tmp_path, name):
    if name in ("sog", "streamed_sog") and not STRAIGHT_WEBP:
        pytest.skip("this OpenImageIO premultiplies WebP alpha (Blender 4.5): SOG is refused here")
    path = _capture(name, testdata, tmp_path)
    assert formats.detect_format(path) == name
    splats, report = formats.read_with_report(path)
    assert report.format == name
    # the same capture as the float PLY it was made from (the glTF pair: test64)
    source = formats.read(testdata / ("test64.ply" if CAPTURES[name].startswith("test64") else "guitar.ply"))
    assert splats.count == source.count > 0
    assert splats.axes == table.row(name).axes
    lo, hi = source.positions.min(axis=0), source.positions.max(axis=0)
    np.testing.assert_allclose(splats.positions.min(axis=0), lo, atol=0.02 * float(np.max(hi - lo)))
    np.testing.assert_allclose(splats.positions.max(axis=0), hi, atol=0.02 * float(np.max(hi - lo)))


@pytest.mark.parametrize("fmt", table.rows(), ids=lambda r: r.name)
def test_rows_follow_the_naming_pattern(fmt):
    """Module m holds read_m; write_m sits in m or m_write; both take the one signature."""
    module, reader = fmt.reader.split(":")
    assert reader == f"read_{module}"
    assert list(inspect.signature(table._resolve(fmt.reader)).parameters)[:3] == ["path", "max_degree", "max_splats"]
    if fmt.writer is not None:
        writer_module, writer = fmt.writer.split(":")
        assert writer == f"write_{module}" and writer_module in (module, f"{module}_write")
        params = inspect.signature(table._resolve(fmt.writer)).parameters
        assert list(params)[:2] == ["path", "splats"]
        assert set(dict(fmt.writer_args)) | set(fmt.options) <= set(params)


def _suffixes_named_in(text: str) -> set:
    return set(re.findall(r"(?<![\w.])(?:[\w-]*)(\.[a-z][a-z0-9]*)\b", text))


def _expected_suffixes(rows) -> set:
    return set(table.suffixes(rows)) | {n[n.rindex("."):] for r in rows for n in r.file_names}


def _cli_help(command: str, dest: str) -> str:
    sub = next(a for a in _parser()._actions if a.dest == "command").choices[command]
    return next(a.help for a in sub._actions if a.dest == dest)


def test_cli_help_offers_exactly_the_rows():
    rows = table.rows()
    assert _suffixes_named_in(_cli_help("info", "file")) == _expected_suffixes(rows)
    assert _suffixes_named_in(_cli_help("import", "files")) == _expected_suffixes(rows)
    assert _suffixes_named_in(_cli_help("convert", "input")) == _expected_suffixes(rows) | {".blend"}
    output = _cli_help("convert", "output")
    assert re.search(r"\((.*?);", output).group(1).split(", ") == [r.name for r in table.rows(writable=True)]


def _ui(bpy) -> dict:
    """What the registered operators and FileHandler offer, read back from Blender's RNA."""
    imp = bpy.ops.import_scene.splatline_gaussians.get_rna_type()
    exp = bpy.ops.export_scene.splatline_gaussians.get_rna_type()
    return {"import_glob": set(imp.properties["filter_glob"].default.split(";")),
            "export_glob": set(exp.properties["filter_glob"].default.split(";")),
            "export_choices": {i.identifier: i.name for i in exp.properties["file_format"].enum_items},
            "drop": set(bpy.types.IO_FH_splatline_gaussians.bl_file_extensions.split(";")),
            "import_label": imp.name, "export_label": exp.name}


def _globs(rows, names=True) -> set:
    return {f"*{e}" for e in table.suffixes(rows)} | ({n for r in rows for n in r.file_names} if names else set())


def test_blender_ui_offers_exactly_the_rows(bpy_empty):
    from addon.blender.ops.io import _EXPORT_EXT

    ui, rows, writable = _ui(bpy_empty), table.rows(), table.rows(writable=True)
    assert ui["import_glob"] == _globs(rows) and ui["export_glob"] == _globs(writable, names=False)
    assert set(ui["export_choices"]) == {r.name.upper() for r in writable}
    # each export choice writes a file its own row reads
    assert {formats.format_for_output("x" + _EXPORT_EXT[key]) for key in ui["export_choices"]} == {
        r.name for r in writable}
    assert ui["drop"] == set(table.suffixes(r for r in rows if r.drop))
    assert ui["import_label"] == _operator_label(rows) and ui["export_label"] == _operator_label(writable)


def _operator_label(rows) -> str:
    """Blender keeps 63 characters of an operator's name: the menu label while it fits
    (every suffix, the closing bracket kept), else the plain name (the menus list them)."""
    label = table.menu_label(rows)
    if len(label) <= 63:
        assert _suffixes_named_in(label) == set(table.suffixes(rows))
        return label
    return "Gaussian Splats"


# The throwaway format: a magic, a count, then float32 positions, scales, quaternions,
# opacities and DC colour; no higher SH bands.
MAGIC = b"TSPL"
FIELDS = (("positions", 3), ("scales", 3), ("rotations", 4), ("opacities", 1), ("sh_dc", 3))


def read_tsplat(path, max_degree=3, max_splats=None) -> SplatSet:
    data = open(path, "rb").read()
    if not data.startswith(MAGIC):
        raise SplatFormatError(path, "not a .tsplat file")
    n, = struct.unpack_from("<I", data, 4)
    flat = np.frombuffer(data, np.float32, offset=8).reshape(n, sum(w for _, w in FIELDS))
    s = SplatSet.allocate(n, 0)
    start = 0
    for name, width in FIELDS:
        value = flat[:, start:start + width]
        setattr(s, name, np.ascontiguousarray(value[:, 0] if width == 1 else value))
        start += width
    return s


def write_tsplat(path, splats: SplatSet) -> None:
    cols = [getattr(splats, name).reshape(splats.count, width) for name, width in FIELDS]
    with open(path, "wb") as f:
        f.write(MAGIC + struct.pack("<I", splats.count) + np.hstack(cols).astype("<f4").tobytes())


TSPLAT = table.Format("tsplat", "Test Splat", "A throwaway test format", ".tsplat", (".tsplat",),
                      read_tsplat, write_tsplat, magic=(MAGIC,), magic_required=True, max_sh_degree=0)


def test_registered_format_is_read_written_and_offered_by_the_cli(testdata, tmp_path, capsys):
    src = formats.read(testdata / "test64.ply")
    with table.registered(TSPLAT):
        formats.write(tmp_path / "a.tsplat", src)
        assert formats.detect_format(tmp_path / "a.tsplat") == "tsplat"
        back = formats.read(tmp_path / "a.tsplat")
        np.testing.assert_array_equal(back.positions, src.positions)
        assert "tsplat" in formats.READ_FORMATS and formats.WRITE_MAX_DEGREE["tsplat"] == 0
        assert ".tsplat" in _suffixes_named_in(_cli_help("info", "file"))
        assert "tsplat" in _cli_help("convert", "output")
        assert main(["convert", str(testdata / "test64.ply"), str(tmp_path / "b.tsplat")]) == 0
        assert "(tsplat, 64 splats, SH degree 0)" in capsys.readouterr().out
        assert main(["info", str(tmp_path / "b.tsplat"), "--json"]) == 0
        assert json.loads(capsys.readouterr().out)["format"] == "tsplat"
        with pytest.raises(SplatFormatError, match="does not start like a .tsplat file"):
            (tmp_path / "bad.tsplat").write_bytes(b"nope" * 4)
            formats.detect_format(tmp_path / "bad.tsplat")
    assert table.row("tsplat") is None and "tsplat" not in formats.WRITE_FORMATS
    assert ".tsplat" not in _suffixes_named_in(_cli_help("info", "file"))
    with pytest.raises(SplatFormatError, match="unknown splat format"):
        formats.detect_format(tmp_path / "a.tsplat")
    with pytest.raises(SplatFormatError, match="cannot write .tsplat files"):
        formats.write(tmp_path / "c.tsplat", src)


@contextlib.contextmanager
def _io_registered_with(fmt):
    """The import/export operators registered again while the table holds `fmt`, and again
    after it is gone (they take the table's lists when they are registered)."""
    from addon.blender.ops import io as io_ops

    with table.registered(fmt):
        io_ops.unregister()
        io_ops.register()
        try:
            yield
        finally:
            io_ops.unregister()
    io_ops.register()


def test_registered_format_in_blender_import_and_export(bpy_empty, testdata, tmp_path):
    bpy = bpy_empty
    formats.write(tmp_path / "seed.ply", formats.read(testdata / "test64.ply"))
    with _io_registered_with(TSPLAT):
        ui = _ui(bpy)
        assert "*.tsplat" in ui["import_glob"] and "*.tsplat" in ui["export_glob"]
        assert ui["export_choices"]["TSPLAT"] == "Test Splat (.tsplat)" and ".tsplat" in ui["drop"]
        assert ui["import_label"] == _operator_label(table.rows())
        assert ui["export_label"] == _operator_label(table.rows(writable=True))
        assert ".tsplat" in table.menu_label(table.rows()) and ".tsplat" in table.menu_label(table.rows(writable=True))
        write_tsplat(tmp_path / "in.tsplat", formats.read(testdata / "test64.ply"))
        assert bpy.ops.import_scene.splatline_gaussians(filepath=str(tmp_path / "in.tsplat")) == {"FINISHED"}
        obj = bpy.context.view_layer.objects.active
        assert len(obj.data.points) == 64
        assert bpy.ops.export_scene.splatline_gaussians(
            filepath=str(tmp_path / "out.ply"), file_format="TSPLAT") == {"FINISHED"}
        assert read_tsplat(tmp_path / "out.tsplat").count == 64
    ui = _ui(bpy)
    assert "*.tsplat" not in ui["import_glob"] and "TSPLAT" not in ui["export_choices"]
    assert ".tsplat" not in ui["drop"]
