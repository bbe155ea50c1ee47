"""XGRIDS LCC (LixelKity / Lixel CyberColor scanners): a `.lcc` JSON meta file (often
meta.lcc) beside index.bin, data.bin and, for SH scenes, shcoef.bin. One level of detail is
read: the finest (LOD 0) unless `lod` names another.

Layout (little endian), as PlayCanvas splat-transform 3.7.0's reader decodes it
(src/lib/readers/read-lcc.ts) and XGRIDS' LCC white paper describes it:
  meta.lcc   JSON: `totalLevel` (LOD count), `splats` (splats per LOD, LOD 0 first: the
             finest), `attributes` [{name, min, max}]: `scale` and `shcoef` (3 numbers each)
             bound the quantised values; `fileType` "Portable" (no SH) or "Quality" (SH
             degree 3; without it, SH when a `shcoef` attribute is present); `version`
             ("5.0" in the white paper), `encoding` ("COMPRESS").
  index.bin  per unit (a quadtree cell): i16 x, i16 y, then per LOD: i32 splat count,
             i64 offset and i32 byte size of its block in data.bin.
  data.bin   32 bytes a splat: f32 x y z | u8 r g b a | u16 scale x y z | u32 rotation |
             u16 normal x y z (unused). colour: SH DC = (c / 255 - 0.5) / C0; opacity a / 255;
             scale lerp(min, max, s / 65535), linear; rotation: bits 0-29 three 10-bit
             components c -> c / 1023 * sqrt 2 - 1 / sqrt 2, bits 30-31 the index in (x, y, z, w)
             of the dropped largest one (rebuilt positive), the other three in order.
  shcoef.bin 64 bytes a splat at twice the unit's data.bin offset: 15 u32 (one per SH
             coefficient, the 16th unused) of r 11 bits | g 10 bits | b 11 bits, each
             lerp(shcoef min, max, v / (2^bits - 1)).
Splats come unit by unit in index.bin order, as splat-transform orders them.
Axis convention: RFU (z up). splat-transform turns LCC data by Euler (90, 0, 180) into its
engine frame and by (0, 0, 180) from the PLY frame: LCC (x, y, z) is PLY (x, -z, y).
environment.bin (a skybox of separate splats) is not read, as splat-transform's conversions
to a single scene leave it out; nor the geo-reference fields (offset, shift, scale, epsg).
"""
from __future__ import annotations

import os

import numpy as np

from ..errors import SplatFormatError
from ..sh import C0
from ..splats import AXES_RFU, SplatSet, sh_coeff_count
from ._common import check_budget, json_object, level_index, normalize_quats_
from .readfile import OpenedFile, read_whole

MAX_META = 16 << 20       # a meta.lcc is a few KB; more is not one
MAX_INDEX = 1 << 30       # 16 bytes per unit and LOD: millions of units
RECORD, SH_RECORD = 32, 64
MAX_LEVELS = 64           # the white paper's example has 9; each is a halving
MAX_OFFSET = 1 << 56      # past any file: bounds the arithmetic on offsets
KNOWN_MAJOR = 5           # the white paper's "5.0"; splat-transform mentions earlier ones
SQRT2 = np.sqrt(2.0)


def read_lcc(path, max_degree: int = 3, max_splats=None, lod=None) -> SplatSet:
    meta = _meta(path)
    levels = meta["levels"]
    lod = level_index(path, lod, levels)
    units = _index(path, levels)[:, lod]
    count = int(units["points"].sum())
    if count != meta["splats"][lod]:
        raise SplatFormatError(path, f"index.bin's units hold {count} splats at LOD {lod}, "
                                     f"meta.lcc says {meta['splats'][lod]}")
    degree = min(max_degree, 3) if meta["sh"] else 0
    check_budget(path, count, 3 * sh_coeff_count(degree), max_splats)
    records = _blocks(_sibling(path, "data.bin"), units, 1, RECORD)
    sh = _blocks(_sibling(path, "shcoef.bin"), units, 2, SH_RECORD) if degree else None
    return _decode(records, sh, meta, degree, 3 if meta["sh"] else 0)


def _sibling(path, name) -> str:
    return os.path.join(os.path.dirname(os.fspath(path)), name)


def level_counts(path) -> list[int]:
    """Splats per LOD, LOD 0 (the finest) first, as the meta file says (info lists them)."""
    return list(_meta(path)["splats"])


def _meta(path) -> dict:
    raw = read_whole(path, MAX_META)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise SplatFormatError(path, "meta.lcc is not UTF-8 text (not an LCC meta file)") from None
    doc = json_object(path, text, "meta.lcc")
    _check_version(path, doc)
    splats, levels = doc.get("splats"), doc.get("totalLevel")
    if not (isinstance(splats, list) and splats and all(_count(s) for s in splats)):
        raise SplatFormatError(path, "meta.lcc `splats` must list each LOD's splat count")
    if not _count(levels) or levels != len(splats) or levels > MAX_LEVELS:
        raise SplatFormatError(path, f"meta.lcc `totalLevel` ({levels!r}) must be the number of LODs "
                                     f"`splats` lists ({len(splats)}), at most {MAX_LEVELS}")
    attributes = doc.get("attributes")
    if not isinstance(attributes, list) or not all(isinstance(a, dict) for a in attributes):
        raise SplatFormatError(path, "meta.lcc `attributes` must be a list of objects")
    named = {a.get("name"): a for a in attributes if isinstance(a.get("name"), str)}
    kind = doc.get("fileType")
    sh = kind == "Quality" or (kind != "Portable" and "shcoef" in named)
    out = {"levels": levels, "splats": splats, "sh": sh, "scale": _bounds(path, named, "scale")}
    if sh:
        out["shcoef"] = _bounds(path, named, "shcoef")
    return out


def _count(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and 0 <= v < 1 << 40


def _check_version(path, doc) -> None:
    """Versions up to the white paper's 5.x are read; a later one may change the layout
    (a guess: no file newer than 5.0 has been seen), so it is refused, not misread."""
    version = doc.get("version")
    if version is not None:
        try:
            major = int(str(version).split(".")[0])
        except ValueError:
            raise SplatFormatError(path, f"meta.lcc version {version!r} is not a version number") from None
        if major > KNOWN_MAJOR or major < 1:
            raise SplatFormatError(path, f"unknown LCC version {version!r} (this reader knows 1 to {KNOWN_MAJOR}.x)")
    encoding = doc.get("encoding", "COMPRESS")
    if encoding != "COMPRESS":
        raise SplatFormatError(path, f"unknown LCC encoding {encoding!r} (known: 'COMPRESS')")


def _bounds(path, named, name) -> np.ndarray:
    """(2, 3) float64: an attribute's min and max."""
    attr = named.get(name)
    if attr is None:
        raise SplatFormatError(path, f"meta.lcc has no `{name}` attribute (its quantisation bounds)")
    try:
        out = np.array([attr["min"], attr["max"]], np.float64)
    except (KeyError, TypeError, ValueError):
        out = None
    if out is None or out.shape != (2, 3) or not np.isfinite(out).all():
        raise SplatFormatError(path, f"meta.lcc `{name}` attribute needs min and max of 3 finite numbers")
    return out


def _index(path, levels: int) -> np.ndarray:
    """(units, levels) records of (points, offset, size)."""
    name = _sibling(path, "index.bin")
    raw = read_whole(name, MAX_INDEX)
    lod = np.dtype([("points", "<i4"), ("offset", "<i8"), ("size", "<i4")])
    unit = np.dtype([("x", "<i2"), ("y", "<i2"), ("lods", lod, (levels,))])
    if len(raw) % unit.itemsize:
        raise SplatFormatError(name, f"is {len(raw)} bytes, not a whole number of {unit.itemsize}-byte "
                                     f"units for {levels} LODs")
    lods = np.frombuffer(raw, unit)["lods"]
    if (lods["points"] < 0).any() or (lods["offset"] < 0).any() or (lods["size"] < 0).any():
        raise SplatFormatError(name, "holds a negative splat count, offset or size")
    if (lods["offset"] >= MAX_OFFSET).any():
        raise SplatFormatError(name, f"holds an offset of {int(lods['offset'].max())}, past any data file")
    if (lods["size"].astype(np.int64) < lods["points"].astype(np.int64) * RECORD).any():
        raise SplatFormatError(name, f"a block is smaller than {RECORD} bytes a splat")
    return lods


def _blocks(name, units, scale: int, record: int) -> np.ndarray:
    """The units' records, back to back: each unit's block at `scale` times its data.bin
    offset (shcoef.bin's are at twice), read into one array this reader owns."""
    pts = units["points"].astype(np.int64)
    offsets = units["offset"][pts > 0] * scale
    pts = pts[pts > 0]
    out = np.empty((int(pts.sum()), record), np.uint8)
    with OpenedFile(name) as f:
        end = offsets + pts * record
        if len(end) and int(end.max()) > f.size:
            raise SplatFormatError(name, f"a block runs to byte {int(end.max())}, past the "
                                         f"end of the file ({f.size} bytes)")
        at = 0
        for offset, n in zip(offsets.tolist(), pts.tolist()):
            f.readinto(out[at:at + n], offset)
            at += n
        f.check_unchanged()
    return out


def _decode(records: np.ndarray, sh, meta: dict, degree: int, in_file: int) -> SplatSet:
    n = len(records)
    s = SplatSet.allocate(0, degree, AXES_RFU)
    s.positions = np.ascontiguousarray(records[:, 0:12]).view("<f4").astype(np.float32)
    colour = records[:, 12:16].astype(np.float32) / np.float32(255)
    s.sh_dc = (colour[:, :3] - np.float32(0.5)) / np.float32(C0)
    s.opacities = np.ascontiguousarray(colour[:, 3])
    half = np.ascontiguousarray(records[:, 16:32]).view("<u2")
    lo, hi = meta["scale"]
    s.scales = half[:, 0:3].astype(np.float32)  # float32 lerps: the peak stays in the budget
    s.scales *= ((hi - lo) / 65535.0).astype(np.float32)
    s.scales += lo.astype(np.float32)
    s.rotations = _rotations(half[:, 3].astype(np.uint32) | (half[:, 4].astype(np.uint32) << 16))
    if sh is not None:
        s.sh_rest = _sh(sh, meta["shcoef"], degree)
    else:
        s.sh_rest = np.zeros((n, 0, 3), np.float32)
    s.sh_degree_in_file = in_file if in_file != degree else None
    return s


def _rotations(v: np.ndarray) -> np.ndarray:
    """wxyz quaternions from the packed u32 (module docstring)."""
    three = np.empty((len(v), 3), np.float32)
    for i in range(3):
        three[:, i] = (v >> (10 * i)) & 1023
    three *= np.float32(SQRT2 / 1023.0)
    three -= np.float32(1.0 / SQRT2)
    largest = np.sqrt(1.0 - np.minimum(1.0, np.einsum("ij,ij->i", three, three)))
    dropped = v >> 30
    xyzw = np.empty((len(v), 4), np.float32)
    for k in range(4):
        rows = dropped == k
        others = [c for c in range(4) if c != k]
        xyzw[np.ix_(rows, others)] = three[rows]
        xyzw[rows, k] = largest[rows]
    return normalize_quats_(np.ascontiguousarray(xyzw[:, [3, 0, 1, 2]]))


def _sh(raw: np.ndarray, bounds: np.ndarray, degree: int) -> np.ndarray:
    """lo + v / top * (hi - lo) in float32, one channel at a time: the float64 lerp of all
    45 coefficients at once made the read's peak twice the memory budget's estimate."""
    k = sh_coeff_count(degree)
    enc = np.ascontiguousarray(raw).view("<u4")[:, :k]
    lo, hi = bounds
    out = np.empty((len(raw), k, 3), np.float32)
    t = np.empty((len(raw), k), np.uint32)
    for c, (shift, bits) in enumerate(((0, 11), (11, 10), (21, 11))):
        np.right_shift(enc, shift, out=t)
        t &= (1 << bits) - 1
        channel = out[:, :, c]
        channel[...] = t
        channel *= np.float32((hi[c] - lo[c]) / ((1 << bits) - 1))
        channel += np.float32(lo[c])
    return out
