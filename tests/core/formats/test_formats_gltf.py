"""glTF KHR_gaussian_splatting: splat-transform's float .glb files decode to the float PLYs they
were made from, our writer round-trips, and broken accessors raise SplatFormatError."""
from __future__ import annotations

import json
import struct

import numpy as np
import pytest

from addon.core.errors import SplatFormatError
from addon.core.formats import detect_format, read, write
from addon.core.formats.gltf import is_splat_gltf, read_gltf
from addon.core.formats.ply import read_ply

FIELDS = ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")


@pytest.mark.parametrize("name", ["guitar", "test64"])
def test_glb_decodes_to_its_float_source(testdata, name):
    # float accessors and a half turn about Z (sign flips only): exact, no tolerance needed
    got, ref = read_gltf(testdata / f"{name}.glb"), read_ply(testdata / f"{name}.ply")
    assert got.axes == ref.axes == "RDF"
    assert got.sh_degree == ref.sh_degree
    for field in FIELDS:
        np.testing.assert_array_equal(getattr(got, field), getattr(ref, field), err_msg=field)


def test_raw_file_is_gltf_frame_xyzw_linear(testdata):
    """The bytes themselves: (-x, -y, z), linear scales, xyzw rotation (pins the facts)."""
    data = (testdata / "test64.glb").read_bytes()
    jlen = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + jlen])
    binary = data[28 + jlen:]
    attrs = doc["meshes"][0]["primitives"][0]["attributes"]

    def raw(semantic, width):
        view = doc["bufferViews"][doc["accessors"][attrs[semantic]]["bufferView"]]
        return np.frombuffer(binary, "<f4", 64 * width, view.get("byteOffset", 0)).reshape(64, width)

    ref = read_ply(testdata / "test64.ply")
    np.testing.assert_array_equal(raw("POSITION", 3), ref.positions * [-1, -1, 1])
    np.testing.assert_array_equal(raw("KHR_gaussian_splatting:SCALE", 3), ref.scales)
    w, x, y, z = ref.rotations.T  # (0,0,0,1) * q, written x, y, z, w, sign as in the file
    np.testing.assert_array_equal(raw("KHR_gaussian_splatting:ROTATION", 4), np.stack([y, -x, -w, z], 1) * -1)


@pytest.mark.parametrize("ext", [".glb", ".gltf"])
def test_write_read_round_trip_is_exact(testdata, tmp_path, ext):
    src = read(testdata / "test64.ply")
    out = tmp_path / f"out{ext}"
    write(out, src)
    assert is_splat_gltf(out)
    back = read(out)
    for field in FIELDS:
        np.testing.assert_array_equal(getattr(back, field), getattr(src, field), err_msg=field)


def test_detection(testdata, tmp_path):
    assert detect_format(testdata / "guitar.glb") == "glb"
    plain = tmp_path / "plain.gltf"
    plain.write_text(json.dumps({"asset": {"version": "2.0"}, "meshes": []}))
    assert detect_format(plain) == "gltf"
    assert not is_splat_gltf(plain)
    with pytest.raises(SplatFormatError, match="Blender's glTF importer"):
        read(plain)


def _doc(testdata, tmp_path):
    src = read(testdata / "test64.ply")
    out = tmp_path / "x.gltf"
    write(out, src)
    return json.loads(out.read_text()), out


def _expect(doc, out, *words):
    out.write_text(json.dumps(doc))
    with pytest.raises(SplatFormatError) as err:
        read(out)
    assert str(out) in str(err.value)
    for w in words:
        assert w in str(err.value), str(err.value)


def test_accessor_outside_its_buffer_view(testdata, tmp_path):
    doc, out = _doc(testdata, tmp_path)
    doc["accessors"][0]["byteOffset"] = 4
    _expect(doc, out, "accessor 0", "outside")


def test_buffer_view_outside_buffer(testdata, tmp_path):
    doc, out = _doc(testdata, tmp_path)
    doc["bufferViews"][2]["byteOffset"] = doc["buffers"][0]["byteLength"]
    _expect(doc, out, "outside its", "buffer")


def test_huge_count_allocates_nothing(testdata, tmp_path):
    doc, out = _doc(testdata, tmp_path)
    doc["accessors"][0]["count"] = 10 ** 12
    _expect(doc, out, "outside")


@pytest.mark.parametrize("edit,words", [
    (lambda d: d["meshes"][0]["primitives"][0]["attributes"].pop("KHR_gaussian_splatting:SCALE"), ["lacks"]),
    (lambda d: d["meshes"][0]["primitives"][0]["attributes"].pop("KHR_gaussian_splatting:SH_DEGREE_2_COEF_1"),
     ["partly defined"]),
    (lambda d: d["accessors"][2].update(type="VEC3"), ["accessor 2"]),
    (lambda d: d["accessors"][3].update(count=3), ["POSITION has 64"]),
    (lambda d: d["meshes"][0]["primitives"][0]["attributes"].update(POSITION=999), ["accessors[999]"]),
    (lambda d: d["buffers"][0].update(uri="../../etc/passwd"), ["leaves"]),
    (lambda d: d["buffers"][0].update(uri="data:application/octet-stream;base64,@@@"), ["base64"]),
    (lambda d: d["meshes"][0]["primitives"][0]["extensions"]["KHR_gaussian_splatting"].update(
        colorSpace="lin_rec709_display"), ["colorSpace"]),
    (lambda d: d["nodes"][0].update(translation=[1, 0, 0]), ["transform"]),
])
def test_nonsense_gltf(testdata, tmp_path, edit, words):
    doc, out = _doc(testdata, tmp_path)
    edit(doc)
    _expect(doc, out, *words)


def test_truncated_glb(testdata, tmp_path):
    bad = tmp_path / "cut.glb"
    bad.write_bytes((testdata / "test64.glb").read_bytes()[:5000])
    with pytest.raises(SplatFormatError, match="truncated"):
        read(bad)
