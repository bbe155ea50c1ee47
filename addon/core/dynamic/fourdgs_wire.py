""".4dgs container framing (Avala AI's format, version 1; facts from fourdgs 0.6.0).

File: magic `\\x89 4DGS 1 \\r\\n`, records, the magic again. A record is u8 opcode, u64 content
length, content; an unknown opcode is skipped by its length, and a known record may carry
appended fields past the ones read here. Little endian; a string is u32 length + UTF-8,
a blob u64 length + bytes, a string map u32 byte length + (key, value) strings.

An attribute stream (inside a Chunk's records block): u8 attribute id, u8 symbol width
(1, 2, 4), u8 mode (0 raw, 1 delta: cumulative sums down the rows, 2 const: one row
repeated), u8 codec (0 deflate, 1 zstd), u8 channels, u32 element count, u64 payload
length, payload. The payload decompresses to the symbols, stored as byte planes (every
symbol's low byte, then the next plane); a symbol is a zigzag-coded signed integer.

Every length is checked against the bytes that remain before anything is sliced or
decompressed; every failure is one SplatFormatError naming the file.
"""
from __future__ import annotations

import struct
import zlib

import numpy as np

from ..errors import SplatFormatError

MAGIC = b"\x894DGS1\r\n"
VERSION_AT = 5  # the major version byte in the magic

HEADER, FOOTER, QUANTIZATION, WINDOW_TABLE, CHUNK = 0x01, 0x02, 0x03, 0x04, 0x05
SH_BAND_STREAM, CHUNK_INDEX, DELTA_CHUNK, OBJECT_TRACK = 0x07, 0x08, 0x10, 0x25

CODECS = {0: "deflate", 1: "zstd"}
CODEC_IDS = {name: ident for ident, name in CODECS.items()}
MODE_RAW, MODE_DELTA, MODE_CONST = 0, 1, 2

_RECORD = struct.Struct("<BQ")
_STREAM = struct.Struct("<BBBBBIQ")
_WIDTH_DTYPE = {1: np.uint8, 2: np.dtype("<u2"), 4: np.dtype("<u4")}


class Reader:
    """A bounds-checked read head over bytes the caller owns; `path` names the file in errors."""

    def __init__(self, path, buf, pos: int = 0, end: int | None = None, what: str = "record"):
        self.path, self.buf, self.pos = path, memoryview(buf), pos
        self.end = len(self.buf) if end is None else end
        self.what = what

    def remaining(self) -> int:
        return self.end - self.pos

    def take(self, n: int) -> memoryview:
        if n < 0 or n > self.end - self.pos:
            raise SplatFormatError(self.path, f"truncated {self.what}: needs {n} bytes at byte {self.pos}, "
                                              f"{self.end - self.pos} remain")
        out = self.buf[self.pos:self.pos + n]
        self.pos += n
        return out

    def unpack(self, fmt: str) -> tuple:
        return struct.unpack_from("<" + fmt, self.take(struct.calcsize("<" + fmt)))

    def u8(self) -> int:
        return self.unpack("B")[0]

    def u32(self) -> int:
        return self.unpack("I")[0]

    def u64(self) -> int:
        return self.unpack("Q")[0]

    def f64(self) -> float:
        return self.unpack("d")[0]

    def string(self) -> str:
        raw = bytes(self.take(self.u32()))
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            raise SplatFormatError(self.path, f"a string in the {self.what} before byte {self.pos} is not UTF-8") \
                from None

    def str_map(self) -> dict:
        block = Reader(self.path, self.take(self.u32()), what=self.what)
        out = {}
        while block.remaining():
            key = block.string()
            out[key] = block.string()
        return out


def check_magic(path, data) -> None:
    head = bytes(data[:len(MAGIC)])
    if head == MAGIC:
        return
    if len(head) == len(MAGIC) and head[:VERSION_AT] == MAGIC[:VERSION_AT] and head[VERSION_AT + 1:] == MAGIC[6:]:
        raise SplatFormatError(path, f".4dgs major version {head[VERSION_AT:VERSION_AT + 1]!r} is not supported "
                                     f"(Splatline reads version 1)")
    raise SplatFormatError(path, "not a .4dgs file (bad magic)")


def records(path, data):
    """(opcode, offset, content memoryview) for each record between the two magics; the
    file must end with the trailing magic right after a whole record."""
    check_magic(path, data)
    end = len(data) - len(MAGIC)
    if end < len(MAGIC) or bytes(data[end:]) != MAGIC:
        raise SplatFormatError(path, "truncated: the file does not end with the .4dgs magic")
    pos = len(MAGIC)
    while pos < end:
        if end - pos < _RECORD.size:
            raise SplatFormatError(path, f"truncated: {end - pos} stray bytes at byte {pos} before the end magic")
        opcode, length = _RECORD.unpack_from(data, pos)
        if length > end - pos - _RECORD.size:
            raise SplatFormatError(path, f"truncated: the record at byte {pos} (opcode 0x{opcode:02X}) claims "
                                         f"{length} bytes, {end - pos - _RECORD.size} remain")
        yield opcode, pos, memoryview(data)[pos + _RECORD.size:pos + _RECORD.size + length]
        pos += _RECORD.size + length


def put_record(opcode: int, content: bytes) -> bytes:
    return _RECORD.pack(opcode, len(content)) + content


def put_string(text: str) -> bytes:
    raw = text.encode("utf-8")
    return struct.pack("<I", len(raw)) + raw


def put_str_map(mapping: dict) -> bytes:
    body = b"".join(put_string(k) + put_string(v) for k, v in sorted(mapping.items()))
    return struct.pack("<I", len(body)) + body


# --- compression ---------------------------------------------------------------------------

def _zstd(path):
    try:
        import zstandard
    except ImportError:
        raise SplatFormatError(path, "uses zstd compression and the zstandard module is not installed") from None
    return zstandard


def decompress(path, body, codec: str, expected: int, what: str) -> bytes:
    """Exactly `expected` bytes from a deflate or zstd body, never more (a small body
    cannot expand past what its header declared)."""
    if codec == "deflate":
        decoder = zlib.decompressobj()
        try:
            out = decoder.decompress(bytes(body), expected + 1)
        except zlib.error as exc:
            raise SplatFormatError(path, f"{what}: corrupt deflate data ({exc})") from None
        if len(out) > expected or decoder.unconsumed_tail:
            raise SplatFormatError(path, f"{what}: inflates past the {expected} bytes its header declares")
        if not decoder.eof:
            raise SplatFormatError(path, f"{what}: deflate data ends before its end marker (truncated or corrupt)")
    elif codec == "zstd":
        zstandard = _zstd(path)
        try:
            out = zstandard.ZstdDecompressor().decompress(bytes(body), max_output_size=expected)
        except zstandard.ZstdError as exc:
            raise SplatFormatError(path, f"{what}: corrupt zstd data ({exc})") from None
    else:
        raise SplatFormatError(path, f"{what}: compression {codec!r} is not one .4dgs defines (deflate, zstd)")
    if len(out) != expected:
        raise SplatFormatError(path, f"{what}: decompresses to {len(out)} bytes, its header declares {expected}")
    return out


def compress(path, raw: bytes, codec: str, level: int) -> bytes:
    if codec == "deflate":
        return zlib.compress(raw, min(level, 9))
    zstandard = _zstd(path)
    return zstandard.ZstdCompressor(level=level).compress(raw)


# --- attribute streams ---------------------------------------------------------------------

def read_stream(path, cur: Reader, want: dict, count: int, what: str):
    """One stream: (attribute id, (count, channels) int64 symbols, or None for an attribute
    not in `want` {id: channels}, which is skipped by its length)."""
    ident, width, mode, codec, channels, n, length = struct.unpack_from("<BBBBBIQ", cur.take(_STREAM.size))
    payload = cur.take(length)
    if ident not in want:
        return ident, None
    where = f"{what}, attribute {ident}"
    if channels != want[ident] or n != count:
        raise SplatFormatError(path, f"{where}: {n} elements x {channels} channels, expected {count} x {want[ident]}")
    if width not in _WIDTH_DTYPE or mode not in (MODE_RAW, MODE_DELTA, MODE_CONST) or codec not in CODECS:
        raise SplatFormatError(path, f"{where}: bad stream header (width {width}, mode {mode}, codec {codec})")
    if n == 0:
        return ident, np.zeros((0, channels), np.int64)
    symbols = channels if mode == MODE_CONST else n * channels
    raw = decompress(path, payload, CODECS[codec], symbols * width, where)
    planes = np.frombuffer(raw, np.uint8).reshape(width, symbols)
    z = np.ascontiguousarray(planes.T).view(_WIDTH_DTYPE[width]).reshape(symbols).astype(np.int64)
    values = (z >> 1) ^ -(z & 1)
    if mode == MODE_CONST:
        return ident, np.broadcast_to(values.reshape(1, channels), (n, channels))
    values = values.reshape(n, channels)
    return ident, np.cumsum(values, axis=0) if mode == MODE_DELTA else values


def put_stream(path, ident: int, values: np.ndarray, codec: str, level: int, what: str) -> bytes:
    """Signed integer symbols (n, channels) as one stream: const mode when every row is
    the same, raw otherwise (the rows stay in capture order, so delta rarely pays)."""
    v = np.asarray(values, np.int64).reshape(len(values), -1)
    n, channels = v.shape
    mode = MODE_CONST if n > 1 and (v == v[:1]).all() else MODE_RAW
    rows = v[:1] if mode == MODE_CONST else v
    z = ((rows << 1) ^ (rows >> 63)).astype(np.uint64).reshape(-1)
    top = int(z.max()) if z.size else 0
    if top > 0xFFFFFFFF:
        raise SplatFormatError(path, f"{what} needs {top.bit_length()}-bit symbols at this quantisation; "
                                     f".4dgs holds 32")
    width = 1 if top <= 0xFF else 2 if top <= 0xFFFF else 4
    shuffled = np.ascontiguousarray(z.astype(_WIDTH_DTYPE[width]).view(np.uint8).reshape(-1, width).T)
    body = compress(path, shuffled.tobytes(), codec, level) if n else b""
    return _STREAM.pack(ident, width, mode, CODEC_IDS[codec], channels, n, len(body)) + body
