"""Helpers shared by the readers: opening files safely, bounding sizes, activations."""
from __future__ import annotations

import json
import os

import numpy as np

from ..atomic import write_group
from .. import budget
from ..errors import SplatFormatError
from ..quaternion import normalize_quats_  # noqa: F401  (the readers import it from here)


def clamp_note(what: str, fmt: str, codes: np.ndarray, top: int, lo: str, hi: str) -> str | None:
    """The line a writer prints when a byte-wide field could not hold some values: `codes`
    (N, ...) are the unclipped codes, 0..top fits; lo and hi the values at the ends. None
    when nothing was clamped (writers say what they change, and only then)."""
    codes = codes.reshape(len(codes), -1)
    low = int((codes < 0).any(axis=1).sum())
    high = int((codes > top).any(axis=1).sum())
    if not (low or high):
        return None
    return (f"{low + high} splats have {what} outside what {fmt} stores ({lo} to {hi}): "
            f"{high} clamped down to {hi}, {low} clamped up to {lo}")


def file_size(path) -> int:
    """Size of a regular, non-empty file; SplatFormatError for anything else."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise SplatFormatError(path, "no such file") from None
    except OSError as exc:
        raise SplatFormatError(path, f"cannot stat: {exc.strerror or exc}") from None
    if os.path.isdir(path):
        raise SplatFormatError(path, "is a directory, not a splat file")
    if not os.path.isfile(path):
        raise SplatFormatError(path, "is not a regular file")
    if st.st_size == 0:
        raise SplatFormatError(path, "file is empty (0 bytes)")
    return int(st.st_size)


def write_file(path, *parts) -> None:
    """Write bytes-like parts (numpy arrays included) to path atomically (core/atomic.py:
    a fsync'd temporary beside the target, renamed over it once every byte is written).
    Any failure raises SplatFormatError naming the file and removes the temporary, so a
    full disk or a killed process never leaves a truncated target (`convert x.ply x.ply`
    used to destroy its input that way).

    Not ndarray.tofile: it writes through a duplicated descriptor and drops the error
    of its close, so a disk that fills up left a truncated file and no error."""
    write_files([(path, parts)])


def write_files(files) -> None:
    """Several files [(path, parts), ...] staged whole, then renamed in order (atomic.write_group)."""
    try:
        write_group(files)
    except OSError as exc:
        raise SplatFormatError(exc.filename or files[0][0], f"cannot write: {exc.strerror or exc}") from None


# What decoding costs per splat at its peak, measured with tracemalloc on testdata/guitar.*
# (degree 0: 110 B/splat for .ply, up to 245 for .spz), plus the higher SH: 4 bytes per
# float32 kept and about as much again in decode temporaries. The memory budget's estimate.
BASE_BYTES_PER_SPLAT = 256
SH_BYTES_PER_COEFFICIENT = 8


def splat_bytes(count: int, rest_floats: int) -> int:
    """What decoding `count` splats with `rest_floats` higher-SH floats each costs at its peak."""
    return int(count) * (BASE_BYTES_PER_SPLAT + SH_BYTES_PER_COEFFICIENT * int(rest_floats))


def check_budget(path, count: int, rest_floats: int, max_splats=None, copies: int = 1) -> None:
    """Refuse a file claiming more splats than the budget, before anything is decompressed
    or allocated from the claim: a 12 KB .spz can legally expand to 20M splats (4 GB).
    max_splats given: that many splats at most (it overrides the memory budget); None: the
    memory budget (core/budget.py: --max-memory, else available memory with headroom).
    rest_floats is the number of higher-SH floats per splat (3 * coefficients); copies, how
    many times the reader holds the splats at once (a glTF's primitives and their merge)."""
    if max_splats is not None:
        if count > max_splats:
            raise SplatFormatError(path, f"holds {count} splats, more than the splat budget of "
                                         f"{max_splats} (max_splats / --max-splats)")
        return
    per_splat = BASE_BYTES_PER_SPLAT + SH_BYTES_PER_COEFFICIENT * rest_floats
    then = budget.planned(count, rest_floats)  # what the command does with them, while held
    budget.check(path, copies * splat_bytes(count, rest_floats) + then, "--max-memory or --max-splats",
                 f"{count} splats at about {per_splat} bytes each"
                 + (f", held {copies} times" if copies > 1 else "")
                 + (f", and {budget.human(then)} to process them" if then else ""))


def level_index(path, lod, levels: int) -> int:
    """The level of detail to read: `lod` (None: 0, the finest), refused unless in 0..levels-1."""
    lod = 0 if lod is None else int(lod)
    if not 0 <= lod < levels:
        raise SplatFormatError(path, f"has LODs 0..{levels - 1} (0 the finest); no LOD {lod}")
    return lod


def json_object(path, text, what: str) -> dict:
    """Parse `text` as a JSON object; anything else is the file's one error."""
    try:
        doc = json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise SplatFormatError(path, f"{what} is not JSON: {exc}") from None
    if not isinstance(doc, dict):
        raise SplatFormatError(path, f"{what} is not a JSON object")
    return doc


def sigmoid_(x: np.ndarray) -> np.ndarray:
    """In-place logistic function."""
    np.negative(x, out=x)
    np.exp(x, out=x)
    x += 1.0
    np.reciprocal(x, out=x)
    return x


def logit(p: np.ndarray) -> np.ndarray:
    """Inverse sigmoid in float64, clamped so that 0 and 1 stay finite."""
    p = np.clip(np.asarray(p, np.float64), 1e-12, 1.0 - 1e-12)
    return np.log(p / (1.0 - p))
