"""glTF 2.0 KHR_gaussian_splatting writer: .glb (one binary chunk) or .gltf (the buffer
embedded as a base64 data URI, so the file stands alone). Float accessors throughout, the
encodings read by gltf.py: linear scales, xyzw rotations, opacity after the sigmoid, SH
coefficients as SH_DEGREE_l_COEF_n, colorSpace srgb_rec709_display, in glTF's own frame.

COLOR_0 is the fallback colour for viewers without the extension. The extension text says it
holds linear values (glTF's rule for COLOR_0), decoded from the sRGB diffuse colour.
"""
from __future__ import annotations

import base64
import json
import struct
from dataclasses import replace

import numpy as np

from ..colorspace import srgb_to_linear
from ..errors import SplatFormatError
from ..sh import C0
from ..splats import SplatSet
from ._common import write_file
from .gltf import EXT, half_turn_z

FLOAT, UNSIGNED_BYTE, ARRAY_BUFFER = 5126, 5121, 34962
TYPES = {1: "SCALAR", 3: "VEC3", 4: "VEC4"}


def _attributes(s: SplatSet) -> list:
    """(semantic, (N, width) array) in file order; s is already in glTF's frame."""
    rgb = np.clip(s.sh_dc.astype(np.float64) * C0 + 0.5, 0.0, 1.0)
    color = np.concatenate([srgb_to_linear(rgb), s.opacities[:, None]], axis=1)
    out = [("POSITION", s.positions),
           ("COLOR_0", np.rint(np.clip(color, 0.0, 1.0) * 255).astype(np.uint8)),
           (f"{EXT}:ROTATION", s.rotations[:, [1, 2, 3, 0]]),
           (f"{EXT}:SCALE", s.scales),
           (f"{EXT}:OPACITY", s.opacities[:, None]),
           (f"{EXT}:SH_DEGREE_0_COEF_0", s.sh_dc)]
    k = 0
    for degree in range(1, s.sh_degree + 1):
        for n in range(2 * degree + 1):
            out.append((f"{EXT}:SH_DEGREE_{degree}_COEF_{n}", s.sh_rest[:, k]))
            k += 1
    return out


def _document(s: SplatSet):
    """(glTF JSON dict without buffer uri, binary buffer bytes)."""
    accessors, views, blobs, attrs, offset = [], [], [], {}, 0
    for semantic, arr in _attributes(s):
        data = np.ascontiguousarray(arr, np.uint8 if arr.dtype == np.uint8 else "<f4")
        acc = {"bufferView": len(views), "componentType": UNSIGNED_BYTE if data.dtype == np.uint8
               else FLOAT, "count": s.count, "type": TYPES[data.shape[1]]}
        if data.dtype == np.uint8:
            acc["normalized"] = True
        if semantic == "POSITION" and s.count:  # required by glTF for POSITION
            acc["min"] = data.min(axis=0).tolist()
            acc["max"] = data.max(axis=0).tolist()
        attrs[semantic] = len(accessors)
        accessors.append(acc)
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": data.nbytes, "target": ARRAY_BUFFER})
        pad = -data.nbytes % 4
        blobs += [data.tobytes(), b"\0" * pad]
        offset += data.nbytes + pad
    prim = {"attributes": attrs, "mode": 0, "extensions": {EXT: {
        "kernel": "ellipse", "colorSpace": "srgb_rec709_display",
        "projection": "perspective", "sortingMethod": "cameraDistance"}}}
    doc = {"asset": {"version": "2.0", "generator": "Splatline"}, "extensionsUsed": [EXT],
           "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": [prim]}], "accessors": accessors, "bufferViews": views,
           "buffers": [{"byteLength": offset}]}
    return doc, b"".join(blobs)


def _glb(doc, binary: bytes) -> list:
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)  # JSON chunk padded with spaces, BIN with zeros
    total = 12 + 8 + len(text) + 8 + len(binary)
    return [struct.pack("<4sII", b"glTF", 2, total), struct.pack("<II", len(text), 0x4E4F534A),
            text, struct.pack("<II", len(binary), 0x004E4942), binary]


def write_gltf(path, splats: SplatSet, binary_container: bool = True) -> None:
    """Write an RDF set (formats.write reframes first); glb or self-contained .gltf."""
    if splats.count == 0:
        raise SplatFormatError(path, "no splats to write (a glTF accessor needs count >= 1)")
    s = replace(splats, positions=splats.positions.copy(), rotations=splats.rotations.copy(),
                sh_rest=splats.sh_rest.copy())
    doc, binary = _document(half_turn_z(s, to_rdf=False))
    if binary_container:
        write_file(path, *_glb(doc, binary))
        return
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(binary).decode()
    write_file(path, json.dumps(doc, separators=(",", ":")).encode())
