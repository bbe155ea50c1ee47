"""glTF 2.0 with KHR_gaussian_splatting (.glb and .gltf): reading.

Facts from the extension text (KhronosGroup/glTF extensions/2.0/Khronos/KHR_gaussian_splatting,
Release Candidate, April 2026) and splat-transform 3.7.0's files:
  POSITION                                   VEC3
  KHR_gaussian_splatting:ROTATION            VEC4 unit quaternion, glTF order x, y, z, w
  KHR_gaussian_splatting:SCALE               VEC3 *linear* scale (an earlier draft said log
                                             space; the current text and splat-transform agree)
  KHR_gaussian_splatting:OPACITY             SCALAR in [0, 1], after the sigmoid
  KHR_gaussian_splatting:SH_DEGREE_l_COEF_n  VEC3 (r, g, b), n from m = -l up to m = l: the
                                             INRIA f_rest order; SH_DEGREE_0_COEF_0 is the DC
  COLOR_0                                    fallback point colour only; ignored here
  extension colorSpace "srgb_rec709_display" is 3DGS's display-referred sRGB, Splatline's own.

Frame: glTF is +X left, +Y up, +Z forward, and splat-transform writes a PLY's splats there
as (-x, -y, z). That is a half turn about Z from RDF, which flips signs and swaps quaternion
components without rounding, so the reader re-expresses the data in RDF (exactly) rather
than adding a fourth axis convention: a .glb and the .ply it came from then read the same.
"""
from __future__ import annotations

import base64
import os
import struct
from urllib.parse import unquote

import numpy as np

from ..errors import SplatFormatError
from ..splats import AXES_RDF, SplatSet, sh_coeff_count
from ._common import check_budget, json_object, normalize_quats_
from .readfile import OpenedFile

EXT = "KHR_gaussian_splatting"
GLB_MAGIC = b"glTF"
MAX_FILE = 1 << 34
MAX_JSON = 256 << 20
COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16,
              5125: np.uint32, 5126: np.float32}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
# per attribute: allowed component types (floats, and the quantized types the text lists)
ALLOWED = {"POSITION": (5126,), f"{EXT}:ROTATION": (5126, 5120, 5122),
           f"{EXT}:SCALE": (5126, 5121, 5123), f"{EXT}:OPACITY": (5126, 5121, 5123)}
# SH basis functions odd under (x, y) -> (-x, -y), in f_rest order (degree 1, 2, 3)
HALF_TURN_Z_SH = np.array([-1, 1, -1, 1, -1, 1, -1, 1, -1, 1, -1, 1, -1, 1, -1], np.float32)


def is_splat_gltf(path) -> bool:
    """True when the file names KHR_gaussian_splatting in extensionsUsed (reads only the
    JSON, bounded): lets the importer leave plain glTF to Blender's own importer."""
    try:
        doc, _ = _load(path)
    except SplatFormatError:
        return False
    used = doc.get("extensionsUsed")
    return isinstance(used, list) and EXT in used


def _glb(path, data: bytes):
    if len(data) < 20:
        raise SplatFormatError(path, "truncated: a .glb needs a 12-byte header and a JSON chunk")
    magic, version, length = struct.unpack_from("<4sII", data)
    if magic != GLB_MAGIC or version != 2:
        raise SplatFormatError(path, f"not a glTF 2 binary (magic {magic!r}, version {version})")
    if length > len(data):
        raise SplatFormatError(path, f"truncated: header says {length} bytes, file has {len(data)}")
    chunks, pos = [], 12
    while pos + 8 <= length:
        size, kind = struct.unpack_from("<II", data, pos)
        if pos + 8 + size > length:
            raise SplatFormatError(path, f"chunk at byte {pos} runs past the end of the file")
        chunks.append((kind, memoryview(data)[pos + 8:pos + 8 + size]))
        pos += 8 + ((size + 3) & ~3)
    if not chunks or chunks[0][0] != 0x4E4F534A:
        raise SplatFormatError(path, "the first .glb chunk is not JSON")
    binary = chunks[1][1] if len(chunks) > 1 and chunks[1][0] == 0x004E4942 else None
    return bytes(chunks[0][1]), binary


def _load(path):
    """(glTF JSON dict, the .glb BIN chunk or None)."""
    with OpenedFile(path) as f:
        if f.size > MAX_FILE:
            raise SplatFormatError(path, f"file is {f.size} bytes, more than {MAX_FILE}")
        if f.read_at(0, 4) != GLB_MAGIC and f.size > MAX_JSON:
            raise SplatFormatError(path, f"glTF JSON is {f.size} bytes, more than {MAX_JSON}")
        data = f.read_rest(0)
        f.check_unchanged()
    if data[:4] == GLB_MAGIC:
        text, binary = _glb(path, data)
    else:
        text, binary = data, None
    return json_object(path, text, "glTF JSON"), binary


def _item(path, doc, key, index, what):
    items = doc.get(key)
    if not (isinstance(index, int) and not isinstance(index, bool) and isinstance(items, list)
            and 0 <= index < len(items) and isinstance(items[index], dict)):
        raise SplatFormatError(path, f"{what} refers to {key}[{index!r}], which does not exist")
    return items[index]


def _uint(path, obj, key, what, default=None) -> int:
    value = obj.get(key, default)
    if not isinstance(value, int) or isinstance(value, bool) or value < 0:
        raise SplatFormatError(path, f"{what}.{key} must be a non-negative integer, not {value!r}")
    return value


class _Buffers:
    """Buffer bytes by index, loaded once: the .glb BIN chunk, a data: URI, or a file beside
    the .gltf (a plain relative path that stays in its folder)."""

    def __init__(self, path, doc, binary):
        self.path, self.doc, self.binary, self.cache = path, doc, binary, {}

    def get(self, index):
        if index not in self.cache:
            self.cache[index] = self._load(index)
        return self.cache[index]

    def _load(self, index):
        buf = _item(self.path, self.doc, "buffers", index, "a bufferView")
        length = _uint(self.path, buf, "byteLength", f"buffers[{index}]")
        uri = buf.get("uri")
        if uri is None:
            if index != 0 or self.binary is None:
                raise SplatFormatError(self.path, f"buffers[{index}] has no uri and no .glb BIN chunk")
            data = self.binary
        elif not isinstance(uri, str):
            raise SplatFormatError(self.path, f"buffers[{index}].uri is not a string")
        elif uri.startswith("data:"):
            data = self._data_uri(index, uri)
        else:
            data = self._file(index, unquote(uri), length)
        if len(data) < length:
            raise SplatFormatError(self.path, f"buffers[{index}] holds {len(data)} bytes, "
                                              f"less than its byteLength {length}")
        return memoryview(data)[:length]

    def _data_uri(self, index, uri):
        head, _, body = uri.partition(",")
        if not head.endswith(";base64"):
            raise SplatFormatError(self.path, f"buffers[{index}] data URI is not base64")
        try:
            return base64.b64decode(body, validate=True)
        except ValueError:
            raise SplatFormatError(self.path, f"buffers[{index}] data URI is not valid base64") from None

    def _file(self, index, name, length):
        if not name:
            raise SplatFormatError(self.path, f"buffers[{index}].uri is empty")
        if "\0" in name:
            raise SplatFormatError(self.path, f"buffers[{index}].uri {name!r} holds a NUL byte")
        if os.path.isabs(name) or ".." in name.replace("\\", "/").split("/") or ":" in name:
            raise SplatFormatError(self.path, f"buffers[{index}].uri {name!r} leaves the glTF's folder")
        local = os.path.join(os.path.dirname(os.fspath(self.path)), name)
        try:  # the error names the glTF, the file the user opened, and then its buffer file
            with OpenedFile(local) as f:
                if f.size < length:
                    raise SplatFormatError(self.path, f"buffers[{index}] file {name} holds fewer "
                                                      f"than the {length} bytes it declares")
                data = f.read_exact(0, length)
                f.check_unchanged()
                return data
        except SplatFormatError as exc:
            if exc.path == os.fspath(self.path):
                raise
            raise SplatFormatError(self.path, f"buffers[{index}] file {name}: {exc.reason}") from None


def _accessor(path, doc, buffers, index, name, width, count=None) -> np.ndarray:
    """(count, width) float32 values of an accessor, every range checked before slicing."""
    what = f"accessor {index} ({name})"
    acc = _item(path, doc, "accessors", index, name)
    ctype, kind = acc.get("componentType"), acc.get("type")
    allowed = ALLOWED.get(name, (5126,))
    if ctype not in allowed or not isinstance(kind, str) or WIDTH.get(kind) != width:
        raise SplatFormatError(path, f"{what} is {kind} of component type {ctype}; expected "
                                     f"{width}-wide of {allowed}")
    if "sparse" in acc or "bufferView" not in acc:
        raise SplatFormatError(path, f"{what}: sparse or bufferView-less accessors are not supported")
    n = _uint(path, acc, "count", what)
    if count is not None and n != count:
        raise SplatFormatError(path, f"{what} has {n} entries, POSITION has {count}")
    view = _item(path, doc, "bufferViews", acc["bufferView"], what)
    buf = buffers.get(_uint(path, view, "buffer", "bufferView"))
    v_off, v_len = _uint(path, view, "byteOffset", "bufferView", 0), _uint(path, view, "byteLength", "bufferView")
    if v_off + v_len > len(buf):
        raise SplatFormatError(path, f"{what}: its bufferView (bytes {v_off}..{v_off + v_len}) lies "
                                     f"outside its {len(buf)}-byte buffer")
    dtype = np.dtype(COMPONENTS[ctype]).newbyteorder("<")
    elem = dtype.itemsize * width
    stride = _uint(path, view, "byteStride", "bufferView", elem)
    a_off = _uint(path, acc, "byteOffset", what, 0)
    if stride < elem or stride % dtype.itemsize or a_off % dtype.itemsize:
        raise SplatFormatError(path, f"{what}: stride {stride} / offset {a_off} do not fit {elem}-byte elements")
    end = a_off + (stride * (n - 1) + elem if n else 0)
    if end > v_len:
        raise SplatFormatError(path, f"{what} reads bytes {a_off}..{end}, outside its "
                                     f"{v_len}-byte bufferView")
    raw = np.frombuffer(buf, np.uint8, v_len, v_off)[a_off:a_off + max(end - a_off, 0)]
    rows = np.lib.stride_tricks.as_strided(raw, (n, elem), (stride, 1)) if n else raw.reshape(0, elem)
    vals = np.ascontiguousarray(rows).view(dtype).reshape(n, width)
    return _normalize(vals, acc.get("normalized", False)).astype(np.float32)


def _normalize(vals: np.ndarray, normalized: bool) -> np.ndarray:
    if not normalized or vals.dtype.kind == "f":
        return vals
    top = np.iinfo(vals.dtype).max  # glTF: unsigned c / max, signed max(c / max, -1)
    return np.maximum(vals.astype(np.float64) / top, -1.0)


def _splat_primitives(path, doc):
    meshes = doc.get("meshes") if isinstance(doc.get("meshes"), list) else []
    found = []
    for m, mesh in enumerate(meshes):
        prims = mesh.get("primitives") if isinstance(mesh, dict) else None
        for p, prim in enumerate(prims if isinstance(prims, list) else []):
            ext = prim.get("extensions", {}) if isinstance(prim, dict) else {}
            if isinstance(ext, dict) and EXT in ext:
                found.append((m, p, prim, ext[EXT]))
    if not found:
        raise SplatFormatError(path, f"no mesh primitive uses {EXT}: not a Gaussian splat glTF "
                                     "(import it with Blender's glTF importer)")
    return found


def _check_nodes(path, doc, meshes) -> None:
    """Refuse node transforms above a splat mesh rather than drop them silently."""
    nodes = doc.get("nodes") if isinstance(doc.get("nodes"), list) else []
    for i, node in enumerate(nodes):
        if not isinstance(node, dict):
            continue
        moved = any(k in node for k in ("matrix", "translation", "rotation", "scale"))
        mesh = node.get("mesh")
        if moved and ((isinstance(mesh, int) and mesh in meshes) or node.get("children")):
            raise SplatFormatError(path, f"nodes[{i}] has a transform; splat glTFs with node "
                                         "transforms are not supported yet")


def _check_extension(path, ext) -> None:
    if not isinstance(ext, dict):
        raise SplatFormatError(path, f"{EXT} extension is not an object")
    kernel, space = ext.get("kernel", "ellipse"), ext.get("colorSpace", "srgb_rec709_display")
    if kernel != "ellipse":
        raise SplatFormatError(path, f"{EXT} kernel {kernel!r} is not supported (only 'ellipse')")
    if space != "srgb_rec709_display":
        raise SplatFormatError(path, f"{EXT} colorSpace {space!r} is not supported: Splatline "
                                     "blends display-referred sRGB ('srgb_rec709_display')")


def _sh_degree(path, attrs) -> int:
    degree = 0
    for d in (1, 2, 3):
        have = [f"{EXT}:SH_DEGREE_{d}_COEF_{n}" in attrs for n in range(2 * d + 1)]
        if all(have) and degree == d - 1:
            degree = d
        elif any(have):
            raise SplatFormatError(path, f"SH degree {d} is partly defined (the extension "
                                         "requires whole degrees, lower ones first)")
    return degree


def _read_primitive(path, doc, buffers, prim, max_degree) -> SplatSet:
    attrs = prim.get("attributes")
    need = ["POSITION", f"{EXT}:ROTATION", f"{EXT}:SCALE", f"{EXT}:OPACITY", f"{EXT}:SH_DEGREE_0_COEF_0"]
    if not isinstance(attrs, dict) or any(a not in attrs for a in need):
        missing = [a for a in need if not isinstance(attrs, dict) or a not in attrs]
        raise SplatFormatError(path, f"splat primitive lacks {', '.join(missing)}")
    get = lambda name, width, n=None: _accessor(path, doc, buffers, attrs[name], name, width, n)  # noqa: E731
    s = SplatSet.allocate(0, 0, AXES_RDF)
    s.positions = get("POSITION", 3)
    n = s.count
    xyzw = get(f"{EXT}:ROTATION", 4, n)
    s.rotations = normalize_quats_(np.ascontiguousarray(xyzw[:, [3, 0, 1, 2]]))
    s.scales = get(f"{EXT}:SCALE", 3, n)
    # the extension calls opacity outside [0, 1] invalid: clamp to the nearest valid value
    # (NaN stays NaN, for the bad-value policy to handle)
    s.opacities = np.clip(get(f"{EXT}:OPACITY", 1, n)[:, 0], 0.0, 1.0)
    s.sh_dc = get(f"{EXT}:SH_DEGREE_0_COEF_0", 3, n)
    s.sh_degree_in_file = _sh_degree(path, attrs)  # the import reports it, not max_degree
    degree = min(s.sh_degree_in_file, max_degree)
    names = [f"{EXT}:SH_DEGREE_{d}_COEF_{i}" for d in range(1, degree + 1) for i in range(2 * d + 1)]
    s.sh_rest = np.stack([get(a, 3, n) for a in names], axis=1) if names else np.zeros((n, 0, 3), np.float32)
    return half_turn_z(s)


def half_turn_z(s: SplatSet, to_rdf: bool = True) -> SplatSet:
    """Turn the set half way about Z in place: glTF's frame -> RDF (to_rdf) or back. Exact:
    only signs change and quaternion components trade places. q and -q are one rotation;
    the signs chosen are those splat-transform's files hold, and the two directions are
    inverses, so a write/read round trip is bit for bit."""
    s.positions[:, :2] *= -1
    w, x, y, z = (s.rotations[:, i].copy() for i in range(4))
    turned = [z, y, -x, -w] if to_rdf else [-z, -y, x, w]
    s.rotations = np.ascontiguousarray(np.stack(turned, axis=1))
    s.sh_rest *= HALF_TURN_Z_SH[: s.sh_rest.shape[1], None]
    return s


def read_gltf(path, max_degree: int = 3, max_splats=None) -> SplatSet:
    doc, binary = _load(path)
    found = _splat_primitives(path, doc)
    _check_nodes(path, doc, {m for m, _, _, _ in found})
    if len(found) > 1:  # one primitive's counts are checked against its buffer's real bytes
        _check_claimed_size(path, doc, found, max_degree, max_splats)
    buffers = _Buffers(path, doc, binary)
    parts = []
    for _, _, prim, ext in found:
        _check_extension(path, ext)
        if prim.get("mode", 4) != 0:
            raise SplatFormatError(path, f"splat primitive mode is {prim.get('mode', 4)}, not POINTS (0)")
        parts.append(_read_primitive(path, doc, buffers, prim, max_degree))
        # glTF is not compressed: every count was checked against its buffer's real bytes
        # before allocating, so the budget can be checked on what was actually read
        check_budget(path, sum(p.count for p in parts), max(p.sh_rest.shape[1] for p in parts) * 3,
                     max_splats)
    return parts[0] if len(parts) == 1 else _concat(parts)


def _check_claimed_size(path, doc, found, max_degree, max_splats) -> None:
    """The budget on what the primitives claim, before any is read: every use of an accessor
    counts (128 primitives reusing one accessor set decode it 128 times), with its SH, and
    several primitives are held twice (the parts and their merge)."""
    accessors = doc.get("accessors") if isinstance(doc.get("accessors"), list) else []
    total, rest = 0, 0
    for _, _, prim, _ in found:
        attrs = prim.get("attributes") if isinstance(prim, dict) else None
        index = attrs.get("POSITION") if isinstance(attrs, dict) else None
        acc = accessors[index] if isinstance(index, int) and 0 <= index < len(accessors) else None
        count = acc.get("count") if isinstance(acc, dict) else None
        if isinstance(count, int) and not isinstance(count, bool) and count > 0:
            total += count
            rest = max(rest, 3 * sh_coeff_count(min(_sh_degree(path, attrs), max_degree)))
    check_budget(path, total, rest, max_splats, copies=2 if len(found) > 1 else 1)


def _concat(parts) -> SplatSet:
    k = min(p.sh_rest.shape[1] for p in parts)
    s = SplatSet.allocate(0, 0, AXES_RDF)
    for name in ("positions", "scales", "rotations", "opacities", "sh_dc"):
        setattr(s, name, np.concatenate([getattr(p, name) for p in parts]))
    s.sh_rest = np.concatenate([p.sh_rest[:, :k] for p in parts])
    s.sh_degree_in_file = min(p.sh_degree_in_file for p in parts)  # what the merge can hold
    return s
