"""Dynamic capture files: sniffing, reading (one file, or Spacetime segments in order) and writing.

    is_dynamic_file(path) -> bool      a PLY whose vertex has trbf_center, a .splatv, a .4dgs
    read_dynamic(path or [paths])      -> DynamicCapture
    write_dynamic(path or [paths], capture)

Several paths are segments played in order: segment k covers capture time [k, k + 1).
.4dgs files (Avala AI's container) are read by fourdgs.py and written by fourdgs_write.py.
"""
from __future__ import annotations

import os

import numpy as np

from ..errors import SplatFormatError
from ..formats._common import file_size
from .capture import DynamicCapture
from .fourdgs import read_fourdgs
from .fourdgs_wire import MAGIC as FOURDGS_FILE_MAGIC
from .fourdgs_write import write_fourdgs
from .ply_read import is_dynamic_names, read_dynamic_ply, vertex_names
from .ply_write import write_dynamic_ply
from .splatv import read_splatv, sniff as sniff_splatv, write_splatv

FOURDGS_MAGIC = FOURDGS_FILE_MAGIC[:5]  # then the major version byte and \r\n: other versions sniff too


def _kind(path) -> str | None:
    """'ply', 'splatv', '4dgs' or None, from the first bytes (and a PLY's bounded header)."""
    file_size(path)
    with open(path, "rb") as f:
        head = f.read(16)
    if head.startswith(FOURDGS_MAGIC):
        return "4dgs"
    if sniff_splatv(head):
        return "splatv"
    if head.startswith(b"ply\n") or head.startswith(b"ply\r"):
        return "ply"
    return None


def is_dynamic_file(path) -> bool:
    """Cheap: reads 16 bytes, and a PLY's header only. False for anything unreadable."""
    try:
        kind = _kind(path)
        return kind in ("splatv", "4dgs") or (kind == "ply" and is_dynamic_names(vertex_names(path)))
    except (SplatFormatError, OSError):
        return False


def _read_one(path, max_splats) -> DynamicCapture:
    try:
        kind = _kind(path)
        if kind == "4dgs":
            return read_fourdgs(path, max_splats)
        if kind == "splatv":
            return read_splatv(path, max_splats).check()
        if kind == "ply":
            if not is_dynamic_names(vertex_names(path)):
                raise SplatFormatError(path, "a static PLY (no trbf_center); read it with core.formats")
            return read_dynamic_ply(path, max_splats).check()
    except OSError as exc:
        raise SplatFormatError(path, f"cannot read: {exc.strerror or exc}") from None
    raise SplatFormatError(path, "not a dynamic capture (.ply with trbf_center, .splatv or .4dgs)")


def read_dynamic(path_or_paths, max_splats=None) -> DynamicCapture:
    """One file, or a list of Spacetime segment files played in order."""
    if isinstance(path_or_paths, (str, os.PathLike)):
        return _read_one(path_or_paths, max_splats)
    paths = list(path_or_paths)
    if not paths:
        raise SplatFormatError(None, "no segment files given")
    parts = []
    for path in paths:
        parts.append(_read_one(path, max_splats))
        if max_splats is not None:
            max_splats = max(0, max_splats - parts[-1].count)
    return join_segments(paths, parts) if len(parts) > 1 else parts[0]


def join_segments(paths, parts) -> DynamicCapture:
    """Segments (each in segment units, one model and SH degree) as one capture over [0, N)."""
    first = parts[0]
    for path, part in zip(paths, parts):
        if part.unit != "segment" or part.segments != 1:
            raise SplatFormatError(path, f"a segment must be one capture in segment units (t in [0, 1]); "
                                         f"this one is in {part.unit}")
        if (part.model, part.sh_degree) != (first.model, first.sh_degree):
            raise SplatFormatError(path, f"segment is {part.model} with SH degree {part.sh_degree}, the first "
                                         f"is {first.model} with degree {first.sh_degree}")
    joined = {name: np.concatenate([getattr(p, name) for p in parts])
              for name in ("positions", "motion", "rotations", "scales", "opacities", "sh_dc", "sh_rest",
                           "t_center", "t_scale")}
    omega = None if first.omega is None else np.concatenate([p.omega for p in parts])
    dropped = {}
    for part in parts:
        for key, value in part.dropped.items():
            dropped[key] = dropped.get(key, 0) + value
    offsets = np.concatenate([[0], np.cumsum([p.count for p in parts])]).astype(np.int64)
    return DynamicCapture(model=first.model, omega=omega, axes=first.axes, t_start=0.0, t_end=float(len(parts)),
                          unit="segment", segment_offsets=offsets, dropped=dropped, source=first.source,
                          **joined).check()


def write_dynamic(path_or_paths, capture: DynamicCapture) -> None:
    """By extension: .ply (Spacetime lite for spacetime captures, linear-motion for linear
    ones; one path per segment), .splatv (one segment) or .4dgs (a 4dgs capture, or one in
    seconds with linear motion and no omega; fourdgs_write.py)."""
    capture.check()
    paths = [path_or_paths] if isinstance(path_or_paths, (str, os.PathLike)) else list(path_or_paths)
    ext = os.path.splitext(os.fspath(paths[0]))[1].lower()
    if ext == ".4dgs":
        if len(paths) != 1:
            raise SplatFormatError(paths[0], "a .4dgs holds one capture; give one path")
        write_fourdgs(paths[0], capture)
    elif ext == ".splatv":
        if len(paths) != 1:
            raise SplatFormatError(paths[0], "a .splatv holds one segment; give one path")
        write_splatv(paths[0], capture)
    elif ext == ".ply":
        write_dynamic_ply(paths, capture)
    else:
        raise SplatFormatError(paths[0], f"cannot write dynamic captures as {ext or 'extension-less'} files; "
                                         f"writable: .ply, .splatv, .4dgs")
