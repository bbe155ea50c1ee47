"""Niantic .spz writer: version 4 (32-byte header, one zstd stream per attribute) by default,
version 3 (one gzip stream) on request. The inverse of spz.py (layout in its docstring).

Quantization follows Niantic's packGaussians (nianticlabs/spz src/cc/load-spz.cc), which
splat-transform 3.7.0 runs through its wasm build:
  positions  24-bit fixed point, 12 fractional bits (fewer only when a coordinate would not
             fit 24 bits; the header says how many, and every reader honours it)
  alpha      round(opacity * 255); colour round((0.15 * dc + 0.5) * 255)
  scale      round((log s + 10) * 16)
  rotation   smallest-three, 9 bits a component, largest made positive
  sh         round(v * 128) + 128 snapped to buckets of 8 (band 1, "sh1Bits" 5) or 16 (bands
             2-3, "shRestBits" 4): fewer distinct bytes compress better, as Niantic does
The file holds RUB, the frame SPZ documents (spz.py): a set in another frame is re-expressed
first (positions, rotations and SH bands, core/reframe.py), so Blender 5.3's wm.spz_import and
Splatline's import of the file agree. No coordinate-system extension is written (RUB is what
its absence means).
"""
from __future__ import annotations

import gzip
import struct

import numpy as np

from ..errors import SplatFormatError
from ..reframe import reframe
from ..splats import AXES_RUB, SplatSet
from ._common import clamp_note, write_file
from .spz import COLOR_SCALE, FLAG_ANTIALIASED, MAGIC

VERSIONS = (3, 4)
FRACTIONAL_BITS = 12
SH1_BUCKET, SH_REST_BUCKET = 8, 16   # 1 << (8 - sh1Bits), 1 << (8 - shRestBits)
ZSTD_LEVEL = 12                      # Niantic's compressZstd default


def _round(x: np.ndarray) -> np.ndarray:
    """C's std::round: halves away from zero (np.rint goes to even and moved 26 of guitar's
    position bytes off splat-transform's)."""
    return np.sign(x) * np.floor(np.abs(x) + 0.5)


def _u8(x: np.ndarray) -> np.ndarray:
    return np.clip(_round(x), 0, 255).astype(np.uint8)


def _fractional_bits(p: np.ndarray) -> int:
    """12 as Niantic, lowered until the largest |coordinate| fits signed 24 bits."""
    biggest = float(np.abs(p).max()) if p.size else 0.0
    bits = FRACTIONAL_BITS
    while bits > 0 and _round(biggest * (1 << bits)) >= (1 << 23):
        bits -= 1
    if _round(biggest * (1 << bits)) >= (1 << 23):
        raise SplatFormatError(None, f"a coordinate of {biggest:g} does not fit spz's 24-bit positions")
    return bits


def _positions(p: np.ndarray, frac: int) -> bytes:
    fixed = _round(p.astype(np.float64) * (1 << frac)).astype(np.int64) & 0xFFFFFF
    b = np.stack([fixed & 0xFF, (fixed >> 8) & 0xFF, (fixed >> 16) & 0xFF], -1)
    return b.astype(np.uint8).tobytes()


def _rotations(wxyz: np.ndarray) -> bytes:
    """u32 smallest-three: index of the largest |component| of x y z w in the top 2 bits,
    then sign + 9-bit magnitude for the others, the first one written in the highest bits."""
    q = wxyz[:, [1, 2, 3, 0]].astype(np.float64)
    norm = np.linalg.norm(q, axis=1, keepdims=True)
    q = np.where(norm > 0, q / np.where(norm > 0, norm, 1), [0.0, 0.0, 0.0, 1.0])  # zero -> identity
    largest = np.argmax(np.abs(q), axis=1)
    rows = np.arange(len(q))
    q *= np.where(q[rows, largest] < 0, -1.0, 1.0)[:, None]  # -q is the same rotation
    mag = np.minimum(511, (511.0 * np.abs(q) / np.sqrt(0.5) + 0.5).astype(np.uint32))
    field = (np.signbit(q).astype(np.uint32) << 9) | mag
    comp = largest.astype(np.uint32)
    for i in range(4):
        keep = largest != i
        comp = np.where(keep, (comp << np.uint32(10)) | field[:, i], comp)
    return comp.astype("<u4").tobytes()


def _sh(rest: np.ndarray) -> bytes:
    q = _round(rest.astype(np.float64) * 128.0) + 128.0
    bucket = np.full(rest.shape[1], SH_REST_BUCKET)
    bucket[:3] = SH1_BUCKET
    b = bucket[None, :, None]
    q = np.floor((q + b // 2) / b) * b  # snap to bucket centres; 128 (zero) is one of them
    return np.clip(q, 0, 255).astype(np.uint8).tobytes()


def scale_note(splats: SplatSet) -> str | None:
    """A byte holds (log s + 10) * 16, so spz stores linear scales from e^-10 (4.5e-05) to
    e^5.94 (379) only; the writer clamps the rest. Say how many splats that changed."""
    codes = _round((np.log(np.maximum(splats.scales.astype(np.float64), 1e-30)) + 10.0) * 16.0)
    return clamp_note("scales", "spz", codes, 255, f"{np.exp(-10.0):.2g}", f"{np.exp(255 / 16 - 10.0):.3g}")


def color_note(splats: SplatSet) -> str | None:
    """A byte holds dc * 0.15 * 255 + 127.5: spz stores SH DC from -3.33 to 3.33 only."""
    codes = _round(splats.sh_dc.astype(np.float64) * (COLOR_SCALE * 255.0) + 0.5 * 255.0)
    span = 127.5 / (COLOR_SCALE * 255.0)
    return clamp_note("colours (SH DC)", "spz", codes, 255, f"{-span:.3g}", f"{span:.3g}")


def sh_note(splats: SplatSet) -> str | None:
    """A byte holds rest * 128 + 128: spz stores higher SH from -1 to 0.992 only."""
    if splats.sh_rest.size == 0:
        return None
    codes = _round(splats.sh_rest.astype(np.float64) * 128.0) + 128.0
    return clamp_note("higher SH", "spz", codes, 255, "-1", f"{127 / 128:.3g}")


def encode_blocks(splats: SplatSet) -> tuple[int, list]:
    """(fractional bits, the six attribute blocks in file order)."""
    frac = _fractional_bits(splats.positions)
    log_s = np.log(np.maximum(splats.scales.astype(np.float64), 1e-30))
    return frac, [
        _positions(splats.positions, frac),
        _u8(splats.opacities.astype(np.float64) * 255.0).tobytes(),
        _u8(splats.sh_dc.astype(np.float64) * (COLOR_SCALE * 255.0) + 0.5 * 255.0).tobytes(),
        _u8((log_s + 10.0) * 16.0).tobytes(),
        _rotations(splats.rotations),
        _sh(splats.sh_rest),
    ]


def encode_spz(splats: SplatSet, version: int = 4) -> bytes:
    return _encode(_turned(splats), version)


def _turned(splats: SplatSet) -> SplatSet:
    """The splats in spz's frame (RUB), as the file holds them: what its bytes clamp."""
    return reframe(splats.check(), AXES_RUB)


def _encode(splats: SplatSet, version: int) -> bytes:
    if version not in VERSIONS:
        raise SplatFormatError(None, f"cannot write spz version {version} (writable: 3, 4)")
    frac, blocks = encode_blocks(splats)
    n, degree = splats.count, splats.sh_degree
    flags = FLAG_ANTIALIASED if splats.antialiased else 0
    if version == 3:
        head = struct.pack("<4sIIBBBB", MAGIC, 3, n, degree, frac, flags, 0)
        return gzip.compress(head + b"".join(blocks), compresslevel=6, mtime=0)
    import zstandard

    if degree == 0:  # Niantic skips empty streams; the reader expects exactly five then
        blocks = blocks[:5]
    cctx = zstandard.ZstdCompressor(level=ZSTD_LEVEL)
    streams = [cctx.compress(b) for b in blocks]
    head = struct.pack("<4sIIBBBBI", MAGIC, 4, n, degree, frac, flags, len(blocks), 32).ljust(32, b"\0")
    toc = b"".join(struct.pack("<QQ", len(c), len(b)) for c, b in zip(streams, blocks))
    return head + toc + b"".join(streams)


def write_spz(path, splats: SplatSet, version: int = 4) -> list:
    """Write the file; returns its notes (what spz had to clamp: scales, colours, SH)."""
    try:
        turned = _turned(splats)
        data = _encode(turned, version)
    except SplatFormatError as exc:
        raise SplatFormatError(path, exc.reason) from None
    write_file(path, data)
    return [note for note in (scale_note(turned), color_note(turned), sh_note(turned)) if note]
