"""PlayCanvas / SuperSplat compressed .ply: a `chunk` element of per-256-splat bounds, a
`vertex` element of four packed uint32 per splat, and an optional `sh` element of uchar
f_rest. Axis convention: RDF (same frame as the INRIA file it was compressed from).

Packing (bits from the most significant end; unorm(v, b) = v / (2^b - 1)):
  packed_position  x 11, y 10, z 11   lerp(chunk min, chunk max, unorm)
  packed_scale     x 11, y 10, z 11   lerp(min_scale, max_scale, unorm) in log space
  packed_color     r 8, g 8, b 8, a 8 colour lerp(min_rgb, max_rgb, unorm) (unorm itself when
                                      the chunk has no colour bounds); dc = (colour - 0.5) / C0;
                                      opacity = unorm(a) (already after the sigmoid)
  packed_rotation  2-bit index of the largest component, then the other three, 10 bits each,
                   as (unorm - 0.5) * sqrt(2); the largest is sqrt(1 - sum of squares).
                   Component order is the file's rot_0..rot_3, i.e. w, x, y, z.
  sh f_rest_i      uchar v -> (v + 0.5) / 256 * 8 - 4  (v = 0 decodes to -4), channel-major
                   like the INRIA f_rest.
These were checked against the float PLYs that splat-transform decoded from the same files
(testdata guitar.ply, test64.ply): see tests/core/formats/test_formats_captures.py.
"""
from __future__ import annotations

import numpy as np

from ..errors import SplatFormatError
from ..sh import C0
from ..splats import AXES_RDF, SplatSet, sh_coeff_count, sh_degree_for
from ._common import check_budget, normalize_quats_
from .ply import antialiased_by_comments, columns, sh_rest_from
from .plyheader import parse_header, read_body
from .readfile import OpenedFile

CHUNK = 256
PACKED = ("packed_position", "packed_rotation", "packed_scale", "packed_color")
BOUNDS = ("min_x", "min_y", "min_z", "max_x", "max_y", "max_z",
          "min_scale_x", "min_scale_y", "min_scale_z", "max_scale_x", "max_scale_y", "max_scale_z")
COLOR_BOUNDS = ("min_r", "min_g", "min_b", "max_r", "max_g", "max_b")


def _unorm(packed: np.ndarray, shift: int, bits: int) -> np.ndarray:
    mask = (1 << bits) - 1
    return ((packed >> np.uint32(shift)) & np.uint32(mask)).astype(np.float32) / np.float32(mask)


def _unpack_111011(packed: np.ndarray) -> np.ndarray:
    return np.stack([_unorm(packed, 21, 11), _unorm(packed, 11, 10), _unorm(packed, 0, 11)], axis=1)


def _lerp(lo: np.ndarray, hi: np.ndarray, t: np.ndarray) -> np.ndarray:
    return lo + (hi - lo) * t


def _unpack_rotation(packed: np.ndarray) -> np.ndarray:
    """Smallest-three quaternion -> (N, 4) wxyz."""
    n = packed.shape[0]
    three = np.stack([_unorm(packed, s, 10) for s in (20, 10, 0)], axis=1)
    three = (three - np.float32(0.5)) * np.float32(np.sqrt(2.0))
    largest = np.sqrt(np.maximum(0.0, 1.0 - np.einsum("ij,ij->i", three, three))).astype(np.float32)
    which = (packed >> np.uint32(30)).astype(np.intp)
    wxyz = np.empty((n, 4), np.float32)
    for j in range(4):  # slot j takes the largest, or the stored component j - (j > largest)
        src = np.clip(j - (j > which), 0, 2)
        stored = np.take_along_axis(three, src[:, None], axis=1)[:, 0]
        wxyz[:, j] = np.where(which == j, largest, stored)
    # stored components can square-sum past 1 (0xFFFFFFFF gives |q| = 1.22): renormalise
    return normalize_quats_(wxyz)


def _require(path, rec: np.ndarray, names, element: str) -> None:
    missing = [p for p in names if p not in rec.dtype.names]
    if missing:
        raise SplatFormatError(path, f"compressed PLY {element} element lacks: {', '.join(missing)}")


def read_compressed_ply(path, max_degree: int = 3, max_splats=None) -> SplatSet:
    with OpenedFile(path) as f:
        header = parse_header(f)
        vertex, sh = header.element("vertex"), header.element("sh")
        check_budget(path, vertex.count if vertex else 0, len(sh.props) if sh else 0, max_splats)
        body = read_body(f, header)
    if "chunk" not in body or "vertex" not in body:
        raise SplatFormatError(path, "compressed PLY needs a chunk and a vertex element")
    chunks, vertex = body["chunk"], body["vertex"]
    _require(path, chunks, BOUNDS, "chunk")
    _require(path, vertex, PACKED, "vertex")
    n = vertex.shape[0]
    if chunks.shape[0] != -(-n // CHUNK):
        raise SplatFormatError(path, f"{chunks.shape[0]} chunks cannot hold {n} splats "
                                     f"({CHUNK} per chunk)")
    owner = np.arange(n) // CHUNK
    b = columns(chunks, BOUNDS)[owner]
    packed = {name: vertex[name].astype(np.uint32) for name in PACKED}
    s = SplatSet.allocate(0, 0, AXES_RDF)
    s.positions = _lerp(b[:, 0:3], b[:, 3:6], _unpack_111011(packed["packed_position"]))
    s.scales = np.exp(_lerp(b[:, 6:9], b[:, 9:12], _unpack_111011(packed["packed_scale"])))
    s.rotations = _unpack_rotation(packed["packed_rotation"])
    color = np.stack([_unorm(packed["packed_color"], sh, 8) for sh in (24, 16, 8)], axis=1)
    if all(name in chunks.dtype.names for name in COLOR_BOUNDS):
        cb = columns(chunks, COLOR_BOUNDS)[owner]
        color = _lerp(cb[:, 0:3], cb[:, 3:6], color)
    s.sh_dc = ((color - np.float32(0.5)) / np.float32(C0)).astype(np.float32)
    s.opacities = _unorm(packed["packed_color"], 0, 8)
    s.sh_rest, s.sh_degree_in_file = _read_sh(path, body.get("sh"), n, max_degree)
    s.antialiased = antialiased_by_comments(header.comments)
    return s


def _read_sh(path, sh, n: int, max_degree: int) -> tuple[np.ndarray, int]:
    """The SH bands up to max_degree, and the degree the file holds."""
    if sh is None:
        return np.zeros((n, 0, 3), np.float32), 0
    if sh.shape[0] != n:
        raise SplatFormatError(path, f"sh element has {sh.shape[0]} rows for {n} splats")
    count = len(sh.dtype.names)
    try:
        degree = sh_degree_for(count // 3) if count % 3 == 0 else -1
    except ValueError:
        degree = -1
    if degree < 0:
        raise SplatFormatError(path, f"sh element has {count} properties, matching no SH degree 1..3")
    _require(path, sh, [f"f_rest_{i}" for i in range(count)], "sh")
    k = count // 3
    rest = sh_rest_from(sh, k, sh_coeff_count(min(degree, max_degree)))
    # v = 0 is the bottom of the range and decodes to -4 exactly
    zero = rest == 0
    rest = (rest + np.float32(0.5)) * np.float32(8.0 / 256.0) - np.float32(4.0)
    rest[zero] = -4.0
    return rest, degree
