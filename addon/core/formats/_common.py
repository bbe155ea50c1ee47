"""Helpers shared by the readers: opening files safely, bounding sizes, activations."""
from __future__ import annotations

import os

import numpy as np

from ..errors import SplatFormatError
from ..quaternion import normalize_quats_  # noqa: F401  (the readers import it from here)


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


def read_bytes(path, limit: int) -> bytes:
    """The whole file, refusing files larger than limit bytes."""
    size = file_size(path)
    if size > limit:
        raise SplatFormatError(path, f"file is {size} bytes, more than the {limit} this format allows")
    with open(path, "rb") as f:
        return f.read()


def write_file(path, *parts) -> None:
    """Write bytes-like parts (numpy arrays included) to path; any failure, the final
    close included, raises SplatFormatError naming the file.

    Not ndarray.tofile: it writes through a duplicated descriptor and drops the error
    of its close, so a disk that fills up left a truncated file and no error."""
    try:
        with open(path, "wb") as f:
            for part in parts:
                f.write(part.view(np.uint8).data if isinstance(part, np.ndarray) else part)
    except OSError as exc:
        raise SplatFormatError(path, f"cannot write: {exc.strerror or exc}") from None


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
