"""Whether a file another writer made (Blender's image and movie writers) is whole, read back
before it replaces anything.

Blender's PNG writer does not check its writes: on a full disk it closes a cut file (8192
bytes, or none) and reports it saved. So a frame is judged by reading its structure back:
- PNG: chunks walked by their lengths from the signature to an IEND that ends the file;
- OpenEXR: the header parsed, and every chunk the offset table lists lying inside the file;
- JPEG: the end-of-image marker last;
- MP4/MOV: top-level boxes that tile the file exactly, a `moov` (the index FFmpeg writes
  when the movie is closed) among them;
- any other format: at least one byte.
`problem(path)` is None for a whole file, else what is wrong, worded for an error line;
`reason(folder, problem)` says "no space left on device" where the folder's disk is full.
"""
from __future__ import annotations

import os
import struct

_PNG = b"\x89PNG\r\n\x1a\n"
_EXR = b"\x76\x2f\x31\x01"
# OpenEXR compression -> scan lines per chunk (the file format's table; 10/11: HTJ2K)
_EXR_LINES = {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 32, 9: 256, 10: 256, 11: 32}
FULL_BELOW = 1 << 20  # free bytes under which a cut file is put down to a full disk


def problem(path: str) -> str | None:
    """None when the file at path is whole, else a short reason ('cut short at 8192 bytes')."""
    try:
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            if size == 0:
                return "empty (0 bytes)"
            head = f.read(16)
            f.seek(0)
            check = _png if head.startswith(_PNG) else _exr if head.startswith(_EXR) \
                else _jpeg if head.startswith(b"\xff\xd8") else _mp4 if head[4:8] == b"ftyp" else None
            if check is not None and not check(f, size):
                return f"cut short at {size} bytes"
    except OSError as exc:
        return exc.strerror or str(exc)
    except (struct.error, ValueError, KeyError):
        return f"unreadable ({size} bytes)"
    return None


def reason(folder: str, what: str) -> str:
    """what, with 'no space left on device' added where the folder's file system is full."""
    try:
        st = os.statvfs(folder or ".")
        full = st.f_bavail * st.f_frsize < FULL_BELOW
    except (OSError, AttributeError):
        full = False
    return f"{what}: no space left on device" if full else what


def _png(f, size) -> bool:
    pos = len(_PNG)
    while pos + 12 <= size:
        f.seek(pos)
        length, kind = struct.unpack(">I4s", f.read(8))
        pos += 12 + length
        if kind == b"IEND":
            return pos == size
    return False


def _jpeg(f, size) -> bool:
    f.seek(max(0, size - 2))
    return f.read(2) == b"\xff\xd9"


def _mp4(f, size) -> bool:
    pos, kinds = 0, set()
    while pos + 8 <= size:
        f.seek(pos)
        length, kind = struct.unpack(">I4s", f.read(8))
        if length == 1:
            (length,) = struct.unpack(">Q", f.read(8))
        elif length == 0:
            length = size - pos
        if length < 8:
            return False
        kinds.add(kind)
        pos += length
    return pos == size and b"moov" in kinds


def _exr_attributes(f) -> dict:
    attrs = {}
    while True:
        name = _cstring(f)
        if not name:
            return attrs
        _cstring(f)  # the attribute's type
        (n,) = struct.unpack("<i", f.read(4))
        attrs[name] = f.read(n)


def _cstring(f) -> bytes:
    out = bytearray()
    while (c := f.read(1)) not in (b"\0", b""):
        out += c
        if len(out) > 255:
            raise ValueError("attribute name too long")
    if c == b"":
        raise ValueError("header cut")
    return bytes(out)


def _exr(f, size) -> bool:
    """Every chunk in the offset tables inside the file (scan-line and tiled, single and
    multi-part; deep data: the tables only)."""
    f.seek(4)
    (flags,) = struct.unpack("<I", f.read(4))
    tiled, deep, multipart = bool(flags & 0x200), bool(flags & 0x800), bool(flags & 0x1000)
    parts = []
    while True:
        attrs = _exr_attributes(f)
        if not attrs:
            break
        parts.append(attrs)
        if not multipart:
            break
    header = (1 if multipart else 0) + (4 if tiled else 1)  # ints before a chunk's byte count
    for attrs in parts:
        count = _exr_chunks(attrs)
        if count is None:  # a layout this check does not know: judged by its size alone
            return True
        offsets = struct.unpack(f"<{count}Q", f.read(8 * count))
        after = f.tell()
        for offset in offsets:
            if not 0 < offset < size:
                return False
            if deep:
                continue
            f.seek(offset + 4 * header)
            (nbytes,) = struct.unpack("<i", f.read(4))
            if nbytes < 0 or offset + 4 * header + 4 + nbytes > size:
                return False
        f.seek(after)
    return bool(parts)


def _exr_chunks(attrs) -> int | None:
    if b"chunkCount" in attrs:
        return struct.unpack("<i", attrs[b"chunkCount"])[0]
    lines = _EXR_LINES.get(attrs[b"compression"][0])
    if b"tiles" in attrs or lines is None:  # single-part tiled: Blender writes none
        return None
    x0, y0, x1, y1 = struct.unpack("<4i", attrs[b"dataWindow"])
    return -(-(y1 - y0 + 1) // lines)

