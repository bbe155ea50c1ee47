"""Niantic .spz, versions 1-3 (one gzip stream) and 4 (zstd streams with a table of contents).

Layout (all little endian):
  v1-v3: gzip( header[16] | positions | alphas | colours | scales | rotations | sh )
         header: magic "NGSP", u32 version, u32 count, u8 sh_degree, u8 fractional_bits,
                 u8 flags, u8 reserved
  v4:    header[32]: magic "NGSP", u32 version = 4, u32 count, u8 sh_degree,
                 u8 fractional_bits, u8 flags, u8 stream_count, u32 toc_offset, reserved;
         at toc_offset, stream_count x (u64 compressed size, u64 uncompressed size);
         then the zstd streams back to back, in the attribute order above.
Per splat: position 3 x float16 (v1) or 3 x signed 24-bit fixed point with fractional_bits
(v2+); alpha u8 = opacity * 255; colour u8 = (0.15 * dc + 0.5) * 255; scale u8 =
(log scale + 10) * 16; rotation 3 x u8 xyz, w = sqrt(1 - |xyz|^2) (v1, v2) or u32
smallest-three: 2-bit index of the largest component of x y z w, then for the other three
(highest index in the lowest bits) 1 sign bit and 9 bits of |c| * sqrt(2) * 511 (v3+);
sh: u8, (v - 128) / 128, coefficient-major with the colour channel fastest.

Axis convention: RUB (right, up, back), the frame SPZ documents for the data inside the
file and the one Niantic's library and Blender 5.3's `wm.spz_import` read; a v4 file whose
header flags hold 0x2 carries extension records ([u32 type][u32 length][payload], from byte
32 to toc_offset), and Adobe's coordinate-system record (type 0xADBE0003, payload a u32 of
Niantic's CoordinateSystem enum: RUB 4, RDF 6, RFU 12) names the stored frame instead.
Until issue 42 this reader said RDF for every file, because splat-transform 3.7's own .spz
files (the testdata guitar.spz and test64.spz) hold their PLY's values unconverted and no
header field tells them apart; real files from Niantic's tools and others rendered upside
down. Such PLY-frame files are now read with the axis override (read(path, axes="RDF"),
`--axes RDF`). Header flag 0x1 marks a capture trained with anti-aliasing
(SplatSet.antialiased).
SH quantization seen in those files: band 1 in steps of 8/128, bands 2-3 in 16/128.

Every size is bounded before it is allocated: the header's count fixes the exact
decompressed size; a count the compressed bytes cannot expand to (deflate expands at most
1032:1, zstd at most 32768:1 per block) is rejected up front, and decompression stops and
fails as soon as a stream would exceed its expected size.
"""
from __future__ import annotations

import struct
import zlib

import numpy as np

from ..errors import SplatFormatError
from ..splats import AXES_RDF, AXES_RFU, AXES_RUB, FILE_MAX_DEGREE, RENDER_MAX_DEGREE, SplatSet, sh_coeff_count
from ._common import check_budget, normalize_quats_
from .readfile import read_whole

MAGIC = b"NGSP"
MAX_FILE = 1 << 33
GZIP_RATIO, ZSTD_RATIO = 1032, 32768
COLOR_SCALE = 0.15
FLAG_ANTIALIASED, FLAG_EXTENSIONS = 0x1, 0x2
EXT_COORDINATE_SYSTEM = 0xADBE0003
# Niantic's CoordinateSystem enum values of the frames Splatline has names for
COORDINATE_SYSTEMS = {4: AXES_RUB, 6: AXES_RDF, 12: AXES_RFU}
COORDINATE_NAMES = {1: "LDB", 2: "RDB", 3: "LUB", 5: "LDF", 7: "LUF", 8: "RUF", 9: "LFD", 10: "RFD",
                    11: "LFU", 13: "LBD", 14: "RBD", 15: "LBU", 16: "RBU"}


def _sizes(version: int, n: int, degree: int) -> list:
    """Byte sizes of the six attribute blocks for n splats."""
    pos = 6 if version == 1 else 9
    rot = 3 if version < 3 else 4
    return [n * pos, n, n * 3, n * 3, n * rot, n * 3 * sh_coeff_count(degree)]


def _parse_header(path, head: bytes, versions, max_splats=None) -> tuple:
    if len(head) < 16:
        raise SplatFormatError(path, "truncated: spz header is shorter than 16 bytes")
    magic, version, n, degree, frac, flags = struct.unpack_from("<4sIIBBB", head)
    if magic != MAGIC:
        raise SplatFormatError(path, f"bad spz magic {magic!r} (expected {MAGIC!r})")
    if version not in versions:
        raise SplatFormatError(path, f"unsupported spz version {version} here (supported: "
                                     f"{', '.join(map(str, versions))})")
    if degree > FILE_MAX_DEGREE:  # SPZ 3+ and Blender 5.3 go to degree 4; bands > 3 are dropped
        raise SplatFormatError(path, f"spz SH degree {degree} is not supported (0..{FILE_MAX_DEGREE})")
    if frac > 24:
        raise SplatFormatError(path, f"spz fractional bits {frac} out of range")
    check_budget(path, n, 3 * sh_coeff_count(degree), max_splats)
    return version, n, degree, frac, flags


def _gunzip_bounded(path, data: bytes, max_splats=None) -> bytes:
    """Whole-file gzip (v1-3): read the header, then exactly the size it implies."""
    d = zlib.decompressobj(16 + zlib.MAX_WBITS)
    try:
        head = d.decompress(data, 16)
        version, n, degree, _, _ = _parse_header(path, head, (1, 2, 3), max_splats)
        expect = sum(_sizes(version, n, degree))
        if expect > GZIP_RATIO * len(data) + 1024:
            raise SplatFormatError(path, f"header claims {n} splats ({expect} bytes), more than "
                                         f"{len(data)} gzip bytes can hold")
        body = d.decompress(d.unconsumed_tail, expect + 1)
    except zlib.error as exc:
        raise SplatFormatError(path, f"corrupt gzip stream: {exc}") from None
    if len(body) > expect:
        raise SplatFormatError(path, f"gzip stream is larger than the {expect} bytes the header implies")
    if len(body) < expect:
        raise SplatFormatError(path, f"truncated: gzip stream holds {len(body)} of {expect} bytes")
    return head + body


def _blocks(body: bytes, sizes) -> list:
    out, pos = [], 0
    for size in sizes:
        out.append(np.frombuffer(body, np.uint8, size, pos))
        pos += size
    return out


def _read_v4(path, data: bytes, max_splats=None) -> tuple:
    version, n, degree, frac, flags = _parse_header(path, data[:16], (4,), max_splats)
    if len(data) < 32:
        raise SplatFormatError(path, "truncated: spz v4 header is shorter than 32 bytes")
    stream_count, toc_offset = data[15], struct.unpack_from("<I", data, 16)[0]
    sizes = _sizes(version, n, degree)
    if degree == 0:
        sizes = sizes[:5]
    if stream_count != len(sizes):
        raise SplatFormatError(path, f"spz v4 has {stream_count} streams, expected {len(sizes)}")
    toc_end = toc_offset + 16 * stream_count
    if toc_offset < 32 or toc_end > len(data):
        raise SplatFormatError(path, "truncated: spz v4 table of contents lies outside the file")
    toc = np.frombuffer(data, "<u8", 2 * stream_count, toc_offset).reshape(-1, 2)
    if (toc[:, 1] != np.array(sizes, np.uint64)).any():
        raise SplatFormatError(path, f"spz v4 stream sizes {toc[:, 1].tolist()} do not match "
                                     f"{n} splats of SH degree {degree} ({sizes})")
    if int(toc[:, 0].sum()) > len(data) - toc_end:
        raise SplatFormatError(path, "truncated: spz v4 streams run past the end of the file")
    if sum(sizes) > ZSTD_RATIO * int(toc[:, 0].sum()) + 1024:
        raise SplatFormatError(path, f"header claims {n} splats, more than the streams can hold")
    blocks, pos = [], toc_end
    for (csize, usize) in toc.tolist():
        blocks.append(_unzstd_bounded(path, data[pos:pos + csize], usize))
        pos += csize
    if degree == 0:
        blocks.append(np.zeros(0, np.uint8))
    return (version, n, degree, frac, flags), blocks


def _extension_axes(path, zone: bytes) -> str:
    """The frame a coordinate-system record names (RUB without one); other records are
    skipped by their length, as Niantic's reader skips types it does not know."""
    axes, pos = AXES_RUB, 0
    while pos + 8 <= len(zone):
        kind, length = struct.unpack_from("<II", zone, pos)
        pos += 8
        if length > len(zone) - pos:
            raise SplatFormatError(path, f"spz extension record 0x{kind:08x} runs past the header zone")
        if kind == EXT_COORDINATE_SYSTEM and length >= 4:
            value = struct.unpack_from("<I", zone, pos)[0]
            if value in COORDINATE_NAMES:
                raise SplatFormatError(path, f"spz coordinate-system extension says "
                                             f"{COORDINATE_NAMES[value]}; Splatline reads RUB, RDF and RFU")
            axes = COORDINATE_SYSTEMS.get(value, AXES_RUB)  # 0: unspecified, RUB as Niantic's
        pos += length
    return axes


def _unzstd_bounded(path, chunk: bytes, expect: int) -> np.ndarray:
    import zstandard

    try:
        reader = zstandard.ZstdDecompressor().stream_reader(chunk, read_across_frames=True)
        out = reader.read(expect + 1) if expect else b""
        extra = reader.read(1) if len(out) == expect and expect else b""
    except zstandard.ZstdError as exc:
        raise SplatFormatError(path, f"corrupt zstd stream: {exc}") from None
    if len(out) + len(extra) > expect:
        raise SplatFormatError(path, f"zstd stream is larger than the {expect} bytes the header implies")
    if len(out) < expect:
        raise SplatFormatError(path, f"truncated: zstd stream holds {len(out)} of {expect} bytes")
    return np.frombuffer(out, np.uint8)


def read_spz(path, max_degree: int = 3, max_splats=None) -> SplatSet:
    data = read_whole(path, MAX_FILE)
    if data[:2] == b"\x1f\x8b":
        raw = _gunzip_bounded(path, data, max_splats)
        head = _parse_header(path, raw[:16], (1, 2, 3))
        blocks = _blocks(raw[16:], _sizes(head[0], head[1], head[2]))
        axes = AXES_RUB
    elif data[:4] == MAGIC:
        head, blocks = _read_v4(path, data, max_splats)
        toc_offset = struct.unpack_from("<I", data, 16)[0]
        axes = _extension_axes(path, data[32:toc_offset]) if head[4] & FLAG_EXTENSIONS else AXES_RUB
    else:
        raise SplatFormatError(path, "not an spz file (neither gzip nor NGSP magic)")
    s = _decode(head, blocks, max_degree)
    s.axes = axes
    s.antialiased = bool(head[4] & FLAG_ANTIALIASED)
    return s


def _decode(head, blocks, max_degree: int) -> SplatSet:
    version, n, degree, frac, _ = head
    pos, alpha, color, scale, rot, sh = blocks
    s = SplatSet.allocate(0, 0, AXES_RUB)
    if version == 1:
        s.positions = pos.view("<f2").reshape(n, 3).astype(np.float32)
    else:
        b = pos.reshape(n, 3, 3).astype(np.int32)
        fixed = b[..., 0] | (b[..., 1] << 8) | (b[..., 2] << 16)
        fixed = np.where(fixed & 0x800000, fixed - (1 << 24), fixed)  # sign-extend 24 bits
        s.positions = (fixed.astype(np.float32) / np.float32(1 << frac))
    s.opacities = alpha.astype(np.float32) / np.float32(255.0)
    s.sh_dc = (color.reshape(n, 3).astype(np.float32) / np.float32(255.0) - np.float32(0.5)) \
        / np.float32(COLOR_SCALE)
    s.scales = np.exp(scale.reshape(n, 3).astype(np.float64) / 16.0 - 10.0).astype(np.float32)
    s.rotations = _rotations(version, rot, n)
    k = sh_coeff_count(degree)
    keep = sh_coeff_count(min(degree, max_degree, RENDER_MAX_DEGREE))
    s.sh_degree_in_file = degree
    rest = sh.reshape(n, k, 3)[:, :keep]
    s.sh_rest = (rest.astype(np.float32) - np.float32(128.0)) / np.float32(128.0)
    return s


def _rotations(version: int, rot: np.ndarray, n: int) -> np.ndarray:
    """-> (N, 4) w x y z."""
    if version < 3:
        xyz = rot.reshape(n, 3).astype(np.float32) / np.float32(127.5) - np.float32(1.0)
        w = np.sqrt(np.maximum(0.0, 1.0 - np.einsum("ij,ij->i", xyz, xyz)))
        return normalize_quats_(np.concatenate([w[:, None], xyz], axis=1).astype(np.float32))
    packed = rot.view("<u4").astype(np.uint32)
    largest = (packed >> np.uint32(30)).astype(np.intp)
    xyzw = np.zeros((n, 4), np.float32)
    order = np.zeros((n, 3), np.intp)  # component index for low, middle, high 10-bit fields
    for k in range(4):
        rows = largest == k
        order[rows] = [i for i in (3, 2, 1, 0) if i != k]
    rows = np.arange(n)
    for field in range(3):
        bits = packed >> np.uint32(10 * field)
        mag = (bits & np.uint32(511)).astype(np.float32) * np.float32(np.sqrt(0.5) / 511.0)
        xyzw[rows, order[:, field]] = np.where(bits & np.uint32(512), -mag, mag)
    xyzw[rows, largest] = np.sqrt(np.maximum(0.0, 1.0 - np.einsum("ij,ij->i", xyzw, xyzw)))
    return normalize_quats_(np.ascontiguousarray(xyzw[:, [3, 0, 1, 2]]))
