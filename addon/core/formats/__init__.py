"""Splat file formats: one module per format, one entry point.

    read(path, sh_degree=None, min_opacity=None, max_count=None, bad="fix", max_splats=None) -> SplatSet
    read_with_report(path, ...) -> (SplatSet, ReadReport)
    write(path, splats, format=None)

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
from ..splats import AXES, AXES_RDF, RENDER_MAX_DEGREE, SplatSet, sh_coeff_count
from ..validate import BadValues, check_values
from ._common import file_size

READ_FORMATS = ("ply", "compressed_ply", "splat", "spz", "sog", "glb", "gltf")
WRITE_FORMATS = ("ply", "compressed_ply", "splat", "spz", "sog", "glb", "gltf")
WRITE_MAX_DEGREE = {f: 3 for f in WRITE_FORMATS} | {"splat": 0}  # .splat stores no higher SH bands
# the convention each writable format holds (spz and sog: RDF, as splat-transform writes them)
WRITE_AXES = {f: AXES_RDF for f in WRITE_FORMATS}
EXTENSIONS = {".ply": "ply", ".splat": "splat", ".spz": "spz", ".sog": "sog", ".glb": "glb", ".gltf": "gltf"}


@dataclass
class ReadReport:
    path: str
    format: str
    count_in_file: int = 0
    sh_degree_in_file: int = 0
    bad: BadValues = field(default_factory=BadValues)

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
    """Format name from the file's magic bytes, falling back to its extension."""
    file_size(path)
    with open(path, "rb") as f:
        head = f.read(4096)
    if head.startswith(b"ply"):
        end = head.find(b"end_header")
        return "compressed_ply" if b"element chunk " in head[: end if end >= 0 else None] else "ply"
    if head[:2] == b"\x1f\x8b" or head[:4] == b"NGSP":
        return "spz"
    if head[:4] == b"glTF":
        return "glb"
    if head[:4] == b"PK\x03\x04" or os.path.basename(os.fspath(path)).lower() == "meta.json":
        return "sog"  # the zip or meta.json itself is checked by the reader
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext in (".ply", ".spz"):
        raise SplatFormatError(path, f"does not start like a {ext} file (bad magic bytes)")
    if ext in EXTENSIONS:
        return EXTENSIONS[ext]
    raise SplatFormatError(path, f"unknown splat format (extension {ext or 'none'!r}, no known magic)")


def _reader(fmt: str):
    if fmt == "ply":
        from .ply import read_ply
        return read_ply
    if fmt == "compressed_ply":
        from .compressed_ply import read_compressed_ply
        return read_compressed_ply
    if fmt == "splat":
        from .splat import read_splat
        return read_splat
    if fmt == "spz":
        from .spz import read_spz
        return read_spz
    if fmt == "sog":
        from .sog import read_sog
        return read_sog
    if fmt in ("glb", "gltf"):
        from .gltf import read_gltf
        return read_gltf
    raise SplatFormatError(None, f"unknown read format {fmt!r}; known: {', '.join(READ_FORMATS)}")


def read_with_report(path, sh_degree=None, min_opacity=None, max_count=None, bad="fix",
                     format=None, axes=None, max_splats=None) -> tuple[SplatSet, ReadReport]:
    """Decode a file, handle bad values by policy `bad` ("fix", "drop", "error"), then apply
    the import options. `axes` overrides the file's axis convention (e.g. "RUB" for an spz
    written by Niantic's own tools); `format` skips detection. `max_splats` is the splat
    budget: a file claiming more is refused before anything is decompressed or allocated
    (None: what fits in available memory; unlike max_count, it never subsamples)."""
    if axes is not None and axes not in AXES:
        raise ValueError(f"axes {axes!r} is not one of {AXES}")
    max_degree = 3 if sh_degree is None else max(0, min(3, int(sh_degree)))
    try:  # open/read can still fail after the stat checks (permission denied, I/O error)
        fmt = format or detect_format(path)
        splats = _reader(fmt)(path, max_degree=max_degree, max_splats=max_splats)
    except OSError as exc:
        raise SplatFormatError(path, f"cannot read: {exc.strerror or exc}") from None
    if axes is not None:
        splats.axes = axes
    in_file = splats.sh_degree if splats.sh_degree_in_file is None else splats.sh_degree_in_file
    report = ReadReport(os.fspath(path), fmt, splats.count, in_file)
    splats, report.bad = check_values(splats, bad, path)
    splats = select(splats, sh_degree, min_opacity, max_count)
    return splats.check(), report


def read(path, sh_degree=None, min_opacity=None, max_count=None, bad="fix", format=None,
         axes=None, max_splats=None) -> SplatSet:
    return read_with_report(path, sh_degree, min_opacity, max_count, bad, format, axes, max_splats)[0]


def format_for_output(path) -> str:
    ext = os.path.splitext(os.fspath(path))[1].lower()
    fmt = EXTENSIONS.get(ext)
    if os.fspath(path).lower().endswith(".compressed.ply"):  # the name promises packed data
        return "compressed_ply"
    if os.path.basename(os.fspath(path)).lower() == "meta.json":  # unbundled SOG
        return "sog"
    if fmt not in WRITE_FORMATS:
        raise SplatFormatError(path, f"cannot write {ext or 'extension-less'} files; "
                                     f"writable: {', '.join(WRITE_FORMATS)}")
    return fmt


def write(path, splats: SplatSet, format=None, **options) -> None:
    """Write in the format's own axis convention: a set in another convention (an spz read
    as RUB, a procedural RFU set) is re-expressed first, so the file means the same thing.
    `options` go to the writer: spz `version` (4 or 3); sog `iterations`, `seed`."""
    fmt = format or format_for_output(path)
    if fmt in WRITE_AXES:
        splats = reframe(splats, WRITE_AXES[fmt])
    if os.path.isdir(path):
        raise SplatFormatError(path, "is a directory")
    _refuse_negative_scales(path, splats)
    with atomic.sigterm_cleans_up(), _claimed(path):
        _write(path, splats, fmt, options)


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
    if fmt == "ply":
        from .ply import write_ply
        write_ply(path, splats)
    elif fmt == "splat":
        from .splat import write_splat
        write_splat(path, splats)
    elif fmt == "compressed_ply":
        from .compressed_ply_write import write_compressed_ply
        write_compressed_ply(path, splats)
    elif fmt == "spz":
        from .spz_write import write_spz
        write_spz(path, splats, **options)
    elif fmt == "sog":  # bundled .sog, or meta.json beside its images
        from .sog_write import write_sog
        write_sog(path, splats, **options)
    elif fmt in ("glb", "gltf"):  # RDF here; the writer turns it into glTF's own frame
        from .gltf_write import write_gltf
        write_gltf(path, splats, binary_container=fmt == "glb")
    else:
        raise SplatFormatError(path, f"unknown write format {fmt!r}; known: {', '.join(WRITE_FORMATS)}")


def _refuse_negative_scales(path, splats: SplatSet) -> None:
    """A negative or NaN scale has no log (the PLY encoding) and is not a size: refuse it
    rather than write NaN. Zero passes (log 0 = -inf reads back as 0)."""
    bad = int((~(splats.scales >= 0)).any(axis=1).sum())
    if bad:
        raise SplatFormatError(path, f"{bad} splats have negative or NaN scales; read the source "
                                     f"with bad='fix' or 'drop' first")
