"""Splat file formats: one module per format, one entry point.

    read(path, sh_degree=None, min_opacity=None, max_count=None, bad="fix", max_splats=None) -> SplatSet
    read_with_report(path, ...) -> (SplatSet, ReadReport)
    write(path, splats, format=None) -> notes: one line each for what the format changed

Readers return SplatSet with activations applied and the file's axis convention.
Every failure raises SplatFormatError(path, reason).
"""
from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass, field

from .. import atomic
from ..errors import SplatFormatError
from ..select import select
from ..reframe import reframe
from ..splats import AXES, RENDER_MAX_DEGREE, SplatSet, sh_coeff_count
from ..validate import BadValues, check_values
from . import readfile, table
from ._common import file_size

# The lists other modules import, derived from the format table on each use (so a row a
# test registers shows in them too).
_DERIVED = {
    "READ_FORMATS": lambda: tuple(r.name for r in table.rows()),
    "WRITE_FORMATS": lambda: tuple(r.name for r in table.rows(writable=True)),
    "WRITE_MAX_DEGREE": lambda: {r.name: r.max_sh_degree for r in table.rows(writable=True)},
    "WRITE_AXES": lambda: {r.name: r.axes for r in table.rows(writable=True)},
    "EXTENSIONS": lambda: {e: r.name for e in table.suffixes(table.rows()) for r in [table.by_name(f"x{e}")]},
}


def __getattr__(name):
    if name in _DERIVED:
        return _DERIVED[name]()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


@dataclass
class ReadReport:
    path: str
    format: str
    count_in_file: int = 0
    sh_degree_in_file: int = 0
    bad: BadValues = field(default_factory=BadValues)
    file_bytes: int | None = None  # the size of the file as it was read (not a later stat)
    levels: list[int] | None = None  # splats per level of detail, finest first (streamed SOG)
    level: int = 0                   # the level read

    @property
    def dropped_sh(self) -> str:
        """What the read left out because Splatline renders SH up to degree 3 ('' if nothing):
        a degree-4 file (SPZ 3+, Blender 5.3) loses band 4, 9 coefficients per channel."""
        if self.sh_degree_in_file <= RENDER_MAX_DEGREE:
            return ""
        first, end = sh_coeff_count(RENDER_MAX_DEGREE), sh_coeff_count(self.sh_degree_in_file)
        return (f"SH degree {self.sh_degree_in_file} in the file; Splatline keeps degree "
                f"{RENDER_MAX_DEGREE} and dropped coefficients {first}..{end - 1} per channel")


def detect_format(path) -> str:
    """Format name from the file's magic bytes, falling back to its name (table.by_name)."""
    file_size(path)
    with open(path, "rb") as f:
        head = f.read(4096)
    fmt = table.by_magic(head) or table.by_name(path)
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if fmt is not None and fmt.magic_required and not fmt.matches(head):
        raise SplatFormatError(path, f"does not start like a {ext} file (bad magic bytes)")
    if fmt is None:
        raise SplatFormatError(path, f"unknown splat format (extension {ext or 'none'!r}, no known magic)")
    return fmt.name  # a zip, a meta.json or a glTF is checked further by its reader


def _row(fmt: str) -> table.Format:
    row = table.row(fmt)
    if row is None:
        raise SplatFormatError(None, f"unknown read format {fmt!r}; known: {', '.join(_DERIVED['READ_FORMATS']())}")
    return row


def _read(row: table.Format, path, max_degree: int, max_splats, lod):
    """The reader's splats at level of detail `lod` (None: the finest); a file of one level
    has level 0 only."""
    if "lod" in row.read_options:
        return row.read(path, max_degree, max_splats, {"lod": lod})
    if lod not in (None, 0):
        raise SplatFormatError(path, f"has one level of detail (0), not level {lod}")
    return row.read(path, max_degree, max_splats)


def read_with_report(path, sh_degree=None, min_opacity=None, max_count=None, bad="fix",
                     format=None, axes=None, max_splats=None,
                     keep_replaced=False, lod=None) -> tuple[SplatSet, ReadReport]:
    """Decode a file, handle bad values by policy `bad` ("fix", "drop", "error"), then apply
    the import options. `axes` overrides the file's axis convention (e.g. "RDF" for an spz
    holding the PLY's values, as splat-transform 3.7 writes them); `format` skips detection.
    `max_splats` is the splat budget: a file claiming more is refused before anything is
    decompressed or allocated (None: what fits in available memory; unlike max_count, it
    never subsamples). keep_replaced: with bad="fix", report.bad.replaced keeps the fixed
    splats' original values (core/validate.py), for statistics that leave the replaced
    values out. `lod`: the level of detail to read from a format that holds several (a
    streamed SOG, LCC, LCC2; None: the finest, 0); a format of one level takes 0 only."""
    if axes is not None and axes not in AXES:
        raise ValueError(f"axes {axes!r} is not one of {AXES}")
    max_degree = 3 if sh_degree is None else max(0, min(3, int(sh_degree)))
    try:  # open/read can still fail after the stat checks (permission denied, I/O error)
        fmt = format or detect_format(path)
        row = _row(fmt)
        with readfile.recording() as opened:
            splats = _read(row, path, max_degree, max_splats, lod)
        levels = row.level_counts(path)
    except OSError as exc:
        raise SplatFormatError(path, f"cannot read: {exc.strerror or exc}") from None
    if axes is not None:
        splats.axes = axes
    in_file = splats.sh_degree if splats.sh_degree_in_file is None else splats.sh_degree_in_file
    report = ReadReport(os.fspath(path), fmt, splats.count, in_file,
                        file_bytes=next((n for p, n in opened if p == os.fspath(path)), None),
                        levels=levels, level=lod or 0)
    splats, report.bad = check_values(splats, bad, path, keep_replaced)
    splats = select(splats, sh_degree, min_opacity, max_count)
    return splats.check(), report


def read(path, sh_degree=None, min_opacity=None, max_count=None, bad="fix", format=None,
         axes=None, max_splats=None, lod=None) -> SplatSet:
    return read_with_report(path, sh_degree, min_opacity, max_count, bad, format, axes, max_splats,
                            lod=lod)[0]


def format_for_output(path) -> str:
    fmt = table.by_name(path)
    if fmt is None or fmt.writer is None:
        ext = os.path.splitext(os.fspath(path))[1].lower()
        raise SplatFormatError(path, f"cannot write {ext or 'extension-less'} files; "
                                     f"writable: {', '.join(_DERIVED['WRITE_FORMATS']())}")
    return fmt.name


def write(path, splats: SplatSet, format=None, **options) -> list:
    """Write in the format's own axis convention: a set in another convention (an spz read
    as RUB, a procedural RFU set) is re-expressed first, so the file means the same thing.
    `options` go to the writer: spz `version` (4 or 3); sog `iterations`, `seed`.
    Returns the writer's notes, one line each for data the format could not hold as it was
    (spz: scales outside its range, clamped, with counts); callers show them, never drop them."""
    fmt = format or format_for_output(path)
    row = table.row(fmt)
    if row is not None and row.writer is not None:
        splats = reframe(splats, row.axes)
    if os.path.isdir(path):
        raise SplatFormatError(path, "is a directory")
    _refuse_negative_scales(path, splats)
    with atomic.sigterm_cleans_up(), _claimed(path):
        return _write(path, splats, fmt, options)


def _claimed(path):
    """The output is claimed while it is written (core/atomic.claim): a second write to the
    same output from another process stops with one SplatFormatError instead of racing."""
    target = os.path.realpath(os.fspath(path))
    if os.path.exists(target) and not os.path.isfile(target):
        return contextlib.nullcontext()  # a device or pipe: nothing to claim
    folder, name = os.path.split(target)
    return _claim_or_refuse(path, os.path.join(folder, f".{name}.splatline.lock"))


@contextlib.contextmanager
def _claim_or_refuse(path, lock_path):
    try:
        with atomic.claim(lock_path, "this output"):
            yield
    except atomic.Claimed as exc:
        raise SplatFormatError(path, str(exc)) from None


def _write(path, splats: SplatSet, fmt: str, options: dict) -> None:
    row = table.row(fmt)
    if row is None or row.writer is None:
        raise SplatFormatError(path, f"unknown write format {fmt!r}; known: {', '.join(_DERIVED['WRITE_FORMATS']())}")
    return row.write(path, splats, options)


def _refuse_negative_scales(path, splats: SplatSet) -> None:
    """A negative or NaN scale has no log (the PLY encoding) and is not a size: refuse it
    rather than write NaN. Zero passes (log 0 = -inf reads back as 0)."""
    bad = int((~(splats.scales >= 0)).any(axis=1).sum())
    if bad:
        raise SplatFormatError(path, f"{bad} splats have negative or NaN scales; read the source "
                                     f"with bad='fix' or 'drop' first")
