"""What fuzzing the SOG and glTF readers found (test_formats_fuzz_containers.py):
one test per defect, each built from the real testdata files and failing on the code before
its fix (see the commit messages)."""
from __future__ import annotations

import io
import json
import struct
import tracemalloc
import zipfile

import numpy as np

from addon.core.formats import read, write
from testing.reader_checks import fails
from testing.webp_support import needs_straight_webp


def _members(path) -> dict:
    with zipfile.ZipFile(path) as z:
        return {name: z.read(name) for name in z.namelist()}


def _zip(path, members: dict, deflated=()) -> None:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for name, data in members.items():
            method = zipfile.ZIP_DEFLATED if name in deflated else zipfile.ZIP_STORED
            z.writestr(zipfile.ZipInfo(name, (1980, 1, 1, 0, 0, 0)), data, method)
    path.write_bytes(buf.getvalue())


def _unit(q) -> bool:
    return bool((np.abs(np.linalg.norm(q.astype(np.float64), axis=1) - 1) < 1e-6).all())


@needs_straight_webp
def test_sog_quaternions_are_unit_even_when_the_three_stored_exceed_one(testdata, tmp_path):
    """quats texel (255, 255, 255, 252): three components of 1/sqrt(2), so the rebuilt
    largest is sqrt(max(0, 1 - 1.5)) = 0 and |q| was sqrt(1.5) = 1.22."""
    from addon.core.formats.webp import read_rgba, write_rgba
    members = _members(testdata / "test64.sog")
    (tmp_path / "q.webp").write_bytes(members["quats.webp"])
    px = read_rgba(tmp_path / "q.webp", 1 << 20)
    px[0, 0] = (255, 255, 255, 252)
    write_rgba(tmp_path / "q.webp", px)
    members["quats.webp"] = (tmp_path / "q.webp").read_bytes()
    _zip(tmp_path / "q.sog", members)
    s = read(tmp_path / "q.sog")
    assert _unit(s.rotations), np.linalg.norm(s.rotations, axis=1)[:3]
    np.testing.assert_allclose(s.rotations[0], [0, 1 / np.sqrt(3), 1 / np.sqrt(3), 1 / np.sqrt(3)], atol=1e-6)
    # the untouched splats decode exactly as before (unit rows are left alone)
    np.testing.assert_array_equal(s.rotations[1:], read(testdata / "test64.sog").rotations[1:])


def test_sog_meta_json_bomb_is_refused_before_inflating(testdata, tmp_path):
    """A 60 MiB meta.json deflated to 60 KB passed the zip-wide ratio check and the 64 MiB
    limit, and was inflated whole (about twice its size at the peak) before the JSON parser
    refused it; a real meta.json is ~14 KB (four 256-entry codebooks)."""
    members = _members(testdata / "test64.sog")
    members["meta.json"] = members["meta.json"] + b" " * (60 << 20)
    path = tmp_path / "bomb.sog"
    _zip(path, members, deflated=("meta.json",))
    assert path.stat().st_size < 200_000
    tracemalloc.start()
    try:
        fails(path, "meta.json")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 << 20, peak


def _glb_parts(path):
    data = path.read_bytes()
    n = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20:20 + n]), data[20 + n + 8:]


def _write_glb(path, doc, binary) -> None:
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    path.write_bytes(struct.pack("<4sII", b"glTF", 2, 28 + len(text) + len(binary))
                     + struct.pack("<II", len(text), 0x4E4F534A) + text
                     + struct.pack("<II", len(binary), 0x004E4942) + binary)


def test_glb_opacity_outside_0_1_is_clamped(testdata, tmp_path):
    """The extension calls OPACITY outside [0, 1] invalid; it was passed on as read (1.5, -3)."""
    doc, binary = _glb_parts(testdata / "test64.glb")
    acc = doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["KHR_gaussian_splatting:OPACITY"]]
    start = doc["bufferViews"][acc["bufferView"]]["byteOffset"] + acc.get("byteOffset", 0)
    binary = bytearray(binary)
    struct.pack_into("<2f", binary, start, 1.5, -3.0)
    path = tmp_path / "op.glb"
    _write_glb(path, doc, bytes(binary))
    s = read(path)
    assert s.opacities[0] == 1.0 and s.opacities[1] == 0.0
    np.testing.assert_array_equal(s.opacities[2:], read(testdata / "test64.glb").opacities[2:])


def test_glb_json_objects_where_names_or_indices_belong(testdata, tmp_path):
    """An accessor "type" or a node "mesh" holding an object or a list raised TypeError
    (unhashable) instead of naming the file. A node whose "mesh" is not an index moves no
    splat mesh, so the splats still read."""
    for value in ({}, [0]):
        doc, binary = _glb_parts(testdata / "test64.glb")
        doc["accessors"][0]["type"] = value
        _write_glb(tmp_path / "type.glb", doc, binary)
        fails(tmp_path / "type.glb", "accessor 0")
        doc, binary = _glb_parts(testdata / "test64.glb")
        doc["nodes"].append({"mesh": value, "translation": [0, 0, 1]})
        _write_glb(tmp_path / "mesh.glb", doc, binary)
        assert read(tmp_path / "mesh.glb").count == 64


def test_gltf_missing_external_buffer_names_the_gltf(testdata, tmp_path):
    """A .gltf whose buffer file is missing (or whose uri is empty) raised an error naming
    the buffer's path (or the glTF's folder: 'is a directory') instead of the .gltf."""
    write(tmp_path / "seed.gltf", read(testdata / "test64.glb"))
    doc = json.loads((tmp_path / "seed.gltf").read_text())
    for uri, words in (("missing.bin", ("missing.bin", "no such file")), ("", ("uri",))):
        doc["buffers"][0]["uri"] = uri
        path = tmp_path / "ext.gltf"
        path.write_text(json.dumps(doc))
        fails(path, *words)
