"""PLY header parsing and body layout (shared by the INRIA and compressed PLY readers).

Only what splat files use is supported: scalar properties (no lists) in binary
little/big endian or ascii bodies. Every count is checked against the file size
before anything is allocated from it. Header and body come through one OpenedFile
(readfile.py): the body is read into arrays this process owns, never memory-mapped.
"""
from __future__ import annotations

import io
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..errors import SplatFormatError
from .readfile import OpenedFile

MAX_HEADER = 1 << 20  # a splat header is a few KB; refuse to scan megabytes for end_header

TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
ENCODINGS = {"binary_little_endian": "<", "binary_big_endian": ">", "ascii": "ascii"}


@dataclass
class Element:
    name: str
    count: int
    props: list = field(default_factory=list)  # [(name, numpy type code without byte order)]
    lists: list = field(default_factory=list)  # list properties: allowed only when count is 0

    def dtype(self, order: str) -> np.dtype:
        return np.dtype([(name, order + code) for name, code in self.props])

    def names(self) -> list:
        return [name for name, _ in self.props]


@dataclass
class Header:
    encoding: str  # "<", ">" or "ascii"
    elements: list
    body_offset: int
    file_size: int
    comments: list = field(default_factory=list)  # the text of each `comment` line, in order

    def element(self, name: str):
        return next((e for e in self.elements if e.name == name), None)


def _read_header_text(f: OpenedFile) -> tuple[str, int]:
    path = f.path
    head = f.read_at(0, min(f.size, MAX_HEADER))
    if not (head.startswith(b"ply\n") or head.startswith(b"ply\r")):
        raise SplatFormatError(path, "not a PLY file (missing 'ply' magic)")
    for marker in (b"end_header\r\n", b"end_header\n", b"end_header\r"):
        end = head.find(marker)
        if end >= 0:
            # comments written by some tools carry UTF-8; keywords and names are ASCII
            return head[:end].decode("utf-8", errors="replace"), end + len(marker)
    if len(head) == MAX_HEADER:  # the header may be fine, only longer than we scan
        raise SplatFormatError(path, f"PLY header is longer than the {MAX_HEADER >> 20} MiB limit "
                                     f"(no end_header in its first {MAX_HEADER} bytes)")
    raise SplatFormatError(path, "PLY header has no end_header (truncated or not a PLY)")


def parse_header(f: OpenedFile) -> Header:
    path, size = f.path, f.size
    text, body_offset = _read_header_text(f)
    encoding, elements, comments = None, [], []
    for lineno, raw in enumerate(text.splitlines()[1:], start=2):
        words = raw.split()
        if words and words[0] == "comment":
            comments.append(raw.strip()[len("comment"):].strip())
        if not words or words[0] in ("comment", "obj_info"):
            continue
        key = words[0]
        if key == "format" and len(words) == 3:
            if words[1] not in ENCODINGS:
                raise SplatFormatError(path, f"unsupported PLY format {words[1]!r}")
            encoding = ENCODINGS[words[1]]
        elif key == "element" and len(words) == 3:
            try:
                count = int(words[2])
            except ValueError:
                count = -1
            if count < 0:
                raise SplatFormatError(path, f"PLY header line {lineno}: bad element count {words[2]!r}")
            elements.append(Element(words[1], count))
        elif key == "property" and len(words) >= 3:
            if not elements:
                raise SplatFormatError(path, f"PLY header line {lineno}: property before any element")
            if words[1] == "list":
                elements[-1].lists.append(words[-1])
                continue
            if words[1] not in TYPES or len(words) != 3:
                raise SplatFormatError(path, f"PLY header line {lineno}: bad property {raw.strip()!r}")
            elements[-1].props.append((words[2], TYPES[words[1]]))
        else:
            raise SplatFormatError(path, f"PLY header line {lineno}: cannot parse {raw.strip()!r}")
    if encoding is None:
        raise SplatFormatError(path, "PLY header has no format line")
    _check_names(path, elements)
    header = Header(encoding, elements, body_offset, size, comments)
    _check_body_size(path, header)
    return header


def _check_names(path, elements) -> None:
    names = [e.name for e in elements]
    if len(set(names)) != len(names):
        raise SplatFormatError(path, f"PLY header repeats an element name: {names}")
    for e in elements:
        props = e.names()
        if len(set(props)) != len(props):
            raise SplatFormatError(path, f"PLY element {e.name!r} repeats a property name")
        if e.lists and e.count:
            # splat files never need lists; an empty 'face' element with one is harmless
            raise SplatFormatError(path, f"PLY list property {e.lists[0]!r} in element {e.name!r} "
                                         f"({e.count} rows) is not supported")


def _check_body_size(path, header: Header) -> None:
    """Reject counts the file cannot hold, before any array is sized from them."""
    available = header.file_size - header.body_offset
    if header.encoding == "ascii":
        # every value takes at least one character plus a separator
        need = sum(e.count * len(e.props) * 2 for e in header.elements)
        unit = "characters"
    else:
        need = sum(e.count * e.dtype("<").itemsize for e in header.elements)
        unit = "bytes"
    if need > available:
        counts = ", ".join(f"{e.count} {e.name}" for e in header.elements)
        raise SplatFormatError(
            path, f"truncated: header claims {counts} needing at least {need} {unit}, "
                  f"but the file holds {available} after the header")


def read_body(f: OpenedFile, header: Header) -> dict:
    """Every element as a structured numpy array this process owns (binary bodies are read
    with readinto, checked block by block; ascii bodies are parsed), then the file is checked
    unchanged since it was opened, so a file rewritten mid-read is an error, never a mix."""
    if header.encoding == "ascii":
        out = _read_ascii(f, header)
    else:
        out, offset = {}, header.body_offset
        for e in header.elements:
            dt = e.dtype(header.encoding)
            out[e.name] = f.read_array(dt, e.count, offset)
            offset += e.count * dt.itemsize
    f.check_unchanged()
    return out


class Records:
    """A binary element's records read block by block into one reused buffer: what
    ply.gather walks, so an INRIA body is never held whole (the decoded arrays are the only
    copy) and each block is copied out while it is still in the CPU's cache.
    Quacks like the structured array for what gather and decode_vertices ask (dtype, shape)."""

    def __init__(self, f: OpenedFile, dtype: np.dtype, count: int, offset: int, per_block: int):
        self.f, self.dtype, self.shape = f, dtype, (count,)
        self.offset, self.per_block = offset, max(1, per_block)

    def blocks(self):
        """(first record index, the records) for each block, in the same reused buffer."""
        n, size = self.shape[0], self.dtype.itemsize
        buf = np.empty(min(self.per_block, n), self.dtype)
        for i in range(0, n, self.per_block):
            b = min(self.per_block, n - i)
            self.f.readinto(buf[:b], self.offset + i * size)
            yield i, buf[:b]


def element_records(f: OpenedFile, header: Header, name: str, per_block: int) -> Records:
    """One binary element as Records; the caller calls f.check_unchanged() after walking it."""
    offset = header.body_offset
    for e in header.elements:
        dt = e.dtype(header.encoding)
        if e.name == name:
            return Records(f, dt, e.count, offset, per_block)
        offset += e.count * dt.itemsize
    raise KeyError(name)


def read_elements(path) -> tuple[Header, dict]:
    """(header, body) of a PLY file by path."""
    with OpenedFile(path) as f:
        header = parse_header(f)
        return header, read_body(f, header)


def _read_ascii(f: OpenedFile, header: Header) -> dict:
    """One line per element row; numpy's C parser (loadtxt with max_rows) keeps this fast
    and memory-light compared with splitting the whole body into Python strings."""
    path = f.path
    text = io.StringIO(f.read_rest(header.body_offset).decode("ascii", errors="replace"))
    out = {}
    for e in header.elements:
        width = len(e.props)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # an empty remainder warns; the count check below reports it
                values = np.loadtxt(text, dtype=np.float64, max_rows=e.count, ndmin=2) if e.count \
                    else np.zeros((0, width))
        except ValueError as exc:
            reason = str(exc).split(";")[0]  # drop numpy's usecols advice
            raise SplatFormatError(path, f"ascii element {e.name!r}: {reason}") from None
        if values.shape[0] != e.count or (e.count and values.shape[1] != width):
            raise SplatFormatError(path, f"truncated: ascii element {e.name!r} has {values.shape[0]} of "
                                         f"{e.count} rows of {width} values")
        arr = np.zeros(e.count, e.dtype("<"))
        for i, name in enumerate(e.names()):
            arr[name] = values[:, i]
        out[e.name] = arr
    return out
