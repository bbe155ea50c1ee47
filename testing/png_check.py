"""Whether a PNG file is whole (a render killed mid-write must never leave a torn frame)."""
from __future__ import annotations

import struct
import zlib


def png_whole(data: bytes) -> bool:
    """Every chunk's CRC right, IEND last, IDAT inflating to exactly the rows IHDR says."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return False
    pos, idat, ihdr = 8, b"", None
    while pos + 12 <= len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + length]
        (crc,) = struct.unpack(">I", data[pos + 8 + length:pos + 12 + length] or b"\0\0\0\0")
        if len(body) != length or zlib.crc32(kind + body) != crc:
            return False
        pos += 12 + length
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
    else:
        return False
    if pos != len(data) or ihdr is None:
        return False
    w, h, depth, colour = ihdr[:4]
    channels = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}[colour]
    try:
        raw = zlib.decompress(idat)
    except zlib.error:
        return False
    return len(raw) == h * (1 + (w * channels * depth + 7) // 8)
