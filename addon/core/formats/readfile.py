"""Reading a splat file into memory the reader owns, one handle for header and body.

Why not mmap: a mapped page past the end of a file that shrank while it was read (a trainer
rewriting a sequence frame, a copy still in progress) raises SIGBUS, which kills the process,
Blender with the user's unsaved work included. Reading with readinto into memory the reader
owns (an INRIA PLY body block by block as it is decoded, plyheader.Records; other formats'
bytes whole, at most what the mapped pages took) turns every such change into one
SplatFormatError:
  shrank    a block comes back short: "file shrank while it was read: expected N bytes, got M"
  grew      fstat after the read shows another size
  rewritten the size is the same but the modification time moved
  replaced  the path now names another file (renamed over it); a file deleted after the
            read is fine: the bytes read are whole and nothing else claims the name
The data a reader returns is therefore the file as it was when it was opened, or an error.

Test hook: `after_block`, when set, is called as after_block(path, k) after the file's block k
is read (k = 0, 1, ... over every read of the file but headers and magic), so fault-injection tests can truncate, grow or replace the file at a
chosen point without sleeps (tests/core/formats/test_read_fault_injection.py). It is None in
use: one `is not None` test per block. `BLOCK` is the block size in bytes.
"""
from __future__ import annotations

import contextvars
import os
import stat

import numpy as np

from ..errors import SplatFormatError
from ._common import file_size

BLOCK = 16 << 20   # large blocks: one read syscall per 16 MiB keeps the copy at memory speed
after_block = None

# (path, bytes) of every file opened on this thread while a `recording()` is active, so
# formats.read_with_report can report the size of the file it read, not a later stat.
_record: contextvars.ContextVar = contextvars.ContextVar("splatline_read_sizes", default=None)


class recording:
    """Context manager collecting [(path, size)] of the files opened inside it (this thread)."""

    def __enter__(self) -> list:
        self.sizes = []
        self._token = _record.set(self.sizes)
        return self.sizes

    def __exit__(self, *exc) -> None:
        _record.reset(self._token)


class OpenedFile:
    """A regular, non-empty file opened once; every read checks its byte count."""

    def __init__(self, path):
        self.path = path
        file_size(path)  # by name first: a FIFO would block open(); names a missing file
        try:
            self._f = open(path, "rb", buffering=0)
        except OSError as exc:
            raise SplatFormatError(path, f"cannot read: {exc.strerror or exc}") from None
        st = os.fstat(self._f.fileno())
        if not stat.S_ISREG(st.st_mode) or st.st_size == 0:
            self._f.close()
            raise SplatFormatError(path, "is not a regular file" if not stat.S_ISREG(st.st_mode)
                                   else "file is empty (0 bytes)")
        self._opened = st
        self._blocks = 0  # blocks read so far, over every readinto (after_block's k)
        self.size = int(st.st_size)
        sizes = _record.get()
        if sizes is not None:
            sizes.append((os.fspath(path), self.size))

    def __enter__(self) -> "OpenedFile":
        return self

    def __exit__(self, *exc) -> None:
        self._f.close()

    def read_at(self, offset: int, n: int) -> bytes:
        """Up to n bytes at offset (fewer at the end of the file: for headers and magic)."""
        self._f.seek(offset)
        return self._f.read(n)

    def readinto(self, buf, offset: int) -> None:
        """Fill buf (a writable buffer) from offset, in blocks, or raise: never a short fill."""
        view = memoryview(buf).cast("B")
        want, done = view.nbytes, 0
        self._f.seek(offset)
        while done < want:
            got = self._f.readinto(view[done:done + min(BLOCK, want - done)])
            if not got:
                raise self._shrank(offset + done)
            done += got
            if after_block is not None:
                after_block(self.path, self._blocks)
            self._blocks += 1

    def _shrank(self, read_to: int) -> SplatFormatError:
        now = os.fstat(self._f.fileno()).st_size
        return SplatFormatError(self.path, f"file shrank while it was read: expected {self.size} "
                                           f"bytes, got {now if now < self.size else read_to}")

    def read_array(self, dtype, count: int, offset: int) -> np.ndarray:
        """count records of dtype at offset, in a new array this process owns."""
        out = np.empty(count, dtype)
        if out.nbytes:
            self.readinto(out, offset)
        return out

    def read_exact(self, offset: int, n: int) -> bytearray:
        """Exactly n bytes at offset (a bytearray: no second copy of the data)."""
        out = bytearray(max(0, n))
        if out:
            self.readinto(out, offset)
        return out

    def read_rest(self, offset: int = 0) -> bytearray:
        """Every byte from offset to the size the file had when it was opened."""
        return self.read_exact(offset, self.size - offset)

    def check_unchanged(self) -> None:
        """Raise if the file grew, was rewritten or was replaced since it was opened."""
        now = os.fstat(self._f.fileno())
        if now.st_size != self.size:
            raise SplatFormatError(self.path, f"file changed size while it was read: "
                                              f"{self.size} bytes when opened, {now.st_size} now")
        if now.st_mtime_ns != self._opened.st_mtime_ns:
            raise SplatFormatError(self.path, "file was rewritten while it was read")
        try:
            named = os.stat(self.path)
        except FileNotFoundError:
            return  # deleted after it was opened: what was read is whole
        except OSError as exc:
            raise SplatFormatError(self.path, f"cannot stat: {exc.strerror or exc}") from None
        if (named.st_dev, named.st_ino) != (now.st_dev, now.st_ino):
            raise SplatFormatError(self.path, "file was replaced while it was read")


def read_whole(path, limit: int) -> bytearray:
    """The whole file, refusing files larger than limit bytes; checked unchanged after."""
    with OpenedFile(path) as f:
        if f.size > limit:
            raise SplatFormatError(path, f"file is {f.size} bytes, more than the {limit} this format allows")
        data = f.read_rest(0)
        f.check_unchanged()
    return data
