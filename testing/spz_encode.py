"""Test-only SPZ encoder (versions 1-4), to exercise the decoder on versions that no
testdata file covers and to build corrupt variants. Written from the layout in
addon/core/formats/spz.py's docstring; v3/v4 decoding is checked against real files."""
from __future__ import annotations

import gzip
import struct

import numpy as np
import zstandard

from addon.core.splats import sh_coeff_count


def _u8(x):
    return np.clip(np.rint(x), 0, 255).astype(np.uint8)


def _positions(p, version, frac):
    if version == 1:
        return p.astype("<f2").tobytes()
    fixed = np.rint(p.astype(np.float64) * (1 << frac)).astype(np.int64) & 0xFFFFFF
    b = np.stack([fixed & 0xFF, (fixed >> 8) & 0xFF, (fixed >> 16) & 0xFF], -1)
    return b.astype(np.uint8).tobytes()


def _rotations(q, version):
    xyzw = q[:, [1, 2, 3, 0]].astype(np.float64)
    if version < 3:
        xyzw *= np.where(xyzw[:, 3:] < 0, -1.0, 1.0)
        return _u8((xyzw[:, :3] + 1.0) * 127.5).tobytes()
    out = np.zeros(len(q), np.uint32)
    for row, v in enumerate(xyzw):
        largest = int(np.argmax(np.abs(v)))
        v = v if v[largest] >= 0 else -v
        comp = largest
        for i in range(4):
            if i != largest:
                mag = min(511, int(round(abs(v[i]) / np.sqrt(0.5) * 511)))
                comp = (comp << 10) | (int(np.signbit(v[i])) << 9) | mag
        out[row] = comp
    return out.astype("<u4").tobytes()


def blocks(s, version, frac=12):
    k = sh_coeff_count(s.sh_degree)
    return [
        _positions(s.positions, version, frac),
        _u8(s.opacities * 255.0).tobytes(),
        _u8((0.15 * s.sh_dc + 0.5) * 255.0).tobytes(),
        _u8((np.log(s.scales) + 10.0) * 16.0).tobytes(),
        _rotations(s.rotations, version),
        _u8(s.sh_rest.reshape(len(s.positions), k * 3) * 128.0 + 128.0).tobytes(),
    ]


def encode(s, version, frac=12, count=None, magic=b"NGSP", parts=None) -> bytes:
    """SPZ bytes; count/magic/parts override the honest values to build bad files."""
    n = s.count if count is None else count
    parts = blocks(s, version, frac) if parts is None else parts
    if version < 4:
        head = struct.pack("<4sIIBBBB", magic, version, n, s.sh_degree, frac, 0, 0)
        return gzip.compress(head + b"".join(parts))
    if s.sh_degree == 0:
        parts = parts[:5]
    streams = [zstandard.ZstdCompressor().compress(p) for p in parts]
    head = struct.pack("<4sIIBBBBI", magic, version, n, s.sh_degree, frac, 0, len(parts), 32)
    head += bytes(32 - len(head))
    toc = b"".join(struct.pack("<QQ", len(c), len(p)) for c, p in zip(streams, parts))
    return head + toc + b"".join(streams)
