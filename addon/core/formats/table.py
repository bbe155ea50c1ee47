"""The format table: one row per splat file format, and everything that lists formats reads it
(detection and dispatch in formats/__init__.py, the File > Import / Export operators, their
menus and the drop FileHandler in blender/ops/io.py, the command line's help).

Adding a format is its module (a `read_<name>(path, max_degree, max_splats)` reader and/or
a `write_<name>(path, splats, **options)` writer) plus one `Format` row in `ROWS`; tests
register throwaway rows with `registered`. docs/ARCHITECTURE.md has the checklist.
"""
from __future__ import annotations

import contextlib
import importlib
import os
from dataclasses import dataclass
from typing import Callable

from ..splats import AXES_RDF, AXES_RFU, AXES_RUB


def _ply_chunked(head: bytes) -> bool:
    """A compressed PLY declares a chunk element in its header (within the first 4 KiB)."""
    end = head.find(b"end_header")
    return b"element chunk " in head[: end if end >= 0 else None]


@dataclass(frozen=True)
class Format:
    """One splat file format.

    name        the id `read_with_report` reports and `format=` takes ("ply")
    label       what menus call it ("INRIA PLY"); the export menu adds the extension
    description the export menu's tooltip
    help        how the command line's help names its files (".sog (or a SOG meta.json)")
    extensions  lower-case suffixes, the one written first (".compressed.ply" may hold a dot)
    file_names  whole file names that are this format (an unbundled SOG's "meta.json")
    magic       byte prefixes a file of it starts with; `sniff` then tells apart rows that
                share a prefix (a compressed PLY's chunk element)
    magic_required  a file with one of its extensions but none of its magic is refused
    reader      "module:function" in this package (imported on first use) or a callable:
                (path, max_degree, max_splats) -> SplatSet
    writer      the same for (path, splats, **writer_args, **options) -> notes (a list of lines
                saying what the format changed: clamped values; None when nothing); None: read only
    writer_args fixed keywords for the writer ((("binary_container", False),))
    options     the write options formats.write passes on (spz "version"); a writer without
                any is called without the caller's options
    read_options    the read options formats.read passes on ("lod": streamed SOG, LCC, LCC2); a reader
                without any is called without them
    levels      for a format with levels of detail, "module:function" (or a callable): path ->
                splats per level, finest first, without decoding (info lists them)
    axes        the convention its files hold; a set in another is re-expressed before writing
    max_sh_degree   the highest SH degree the writer stores
    drop        offered for drag-and-drop (FileHandler): not for extensions other importers own
    write_bytes what the writer allocates at its peak beyond the splats it is given: bytes per
                splat and per higher-SH float (core/budget.after_read; measured at 1M splats,
                degrees 0 and 3, with a sixth to spare: bench/memory_budget_bench.py)
    """
    name: str
    label: str
    description: str
    help: str
    extensions: tuple[str, ...]
    reader: str | Callable
    writer: str | Callable | None = None
    magic: tuple[bytes, ...] = ()
    sniff: Callable[[bytes], bool] | None = None
    magic_required: bool = False
    file_names: tuple[str, ...] = ()
    writer_args: tuple[tuple[str, object], ...] = ()
    options: tuple[str, ...] = ()
    read_options: tuple[str, ...] = ()
    levels: str | Callable | None = None
    axes: str = AXES_RDF
    max_sh_degree: int = 3
    drop: bool = True
    write_bytes: tuple[int, int] = (0, 0)

    def write_cost(self, count: int, rest_floats: int) -> int:
        per_splat, per_float = self.write_bytes
        return int(count) * (per_splat + per_float * int(rest_floats))

    def matches(self, head: bytes) -> bool:
        """Whether a file starting with `head` (its first 4 KiB) is this format by its bytes."""
        return any(head.startswith(m) for m in self.magic) and (self.sniff is None or self.sniff(head))

    def read(self, path, max_degree: int, max_splats, options: dict | None = None):
        given = {k: v for k, v in (options or {}).items() if k in self.read_options}
        return _resolve(self.reader)(path, max_degree=max_degree, max_splats=max_splats, **given)

    def level_counts(self, path) -> list[int] | None:
        """Splats per level of detail, finest first; None for a format without levels."""
        return None if self.levels is None else list(_resolve(self.levels)(path))

    def write(self, path, splats, options: dict) -> list:
        """The writer's notes: one line each for what the format could not keep as it was
        (spz's clamped scales); a writer that returns None changed nothing."""
        notes = _resolve(self.writer)(path, splats, **dict(self.writer_args), **(options if self.options else {}))
        return list(notes or [])


def _resolve(target):
    if callable(target):
        return target
    module, function = target.split(":")
    return getattr(importlib.import_module(f".{module}", __package__), function)


ROWS: list[Format] = [
    Format("ply", "INRIA PLY", "Float PLY with every SH band: a lossless round trip", ".ply", (".ply",),
           "ply:read_ply", "ply:write_ply", magic=(b"ply",), sniff=lambda head: not _ply_chunked(head),
           magic_required=True, write_bytes=(16, 4)),
    Format("compressed_ply", "Compressed PLY",
           "PlayCanvas/SuperSplat packed PLY: about a quarter of the float PLY", "compressed .ply",
           (".compressed.ply",), "compressed_ply:read_compressed_ply",
           "compressed_ply_write:write_compressed_ply", magic=(b"ply",), sniff=_ply_chunked,
           magic_required=True, write_bytes=(190, 9)),
    Format("splat", "antimatter15", "Compact 32-byte splats, no higher SH", ".splat", (".splat",),
           "splat:read_splat", "splat:write_splat", max_sh_degree=0, write_bytes=(56, 0)),  # no higher SH bands stored
    # spz holds RUB, as its documentation, Niantic's library and Blender 5.3 say; sog holds
    # RDF, as splat-transform writes it (docs/ARCHITECTURE.md: core/axes.py)
    Format("spz", "Niantic SPZ", "SPZ v4 (zstd streams), about a tenth of the float PLY", ".spz", (".spz",),
           "spz:read_spz", "spz_write:write_spz", magic=(b"\x1f\x8b", b"NGSP"), magic_required=True,
           options=("version",), axes=AXES_RUB, write_bytes=(100, 30)),
    Format("sog", "PlayCanvas SOG", "SOG v2 bundled: WebP images in a zip, the smallest",
           ".sog (or a SOG meta.json)", (".sog",), "sog:read_sog", "sog_write:write_sog",
           magic=(b"PK\x03\x04",), file_names=("meta.json",), options=("iterations", "seed"),
           write_bytes=(170, 2)),
    # GaussianSplats3D's SplatBuffer: read only, no magic (it starts with its version bytes)
    Format("ksplat", "GaussianSplats3D KSPLAT", "mkkellogg's three.js viewer format, levels 0-2",
           ".ksplat", (".ksplat",), "ksplat:read_ksplat", max_sh_degree=2),
    # streamed SOG: a folder of SOG chunks at several levels of detail, read one level at a time
    Format("streamed_sog", "PlayCanvas streamed SOG", "lod-meta.json and its SOG chunks, levels of detail",
           "a streamed SOG lod-meta.json", (), "streamed_sog:read_streamed_sog",
           file_names=("lod-meta.json",), read_options=("lod",), levels="streamed_sog:level_counts",
           drop=False),
    # glTF: RDF in and out; the reader and writer turn it into glTF's own frame. Never offered
    # for drops: a FileHandler cannot see the file, so it would stand in front of every glTF.
    Format("glb", "glTF binary", "KHR_gaussian_splatting glTF, one binary file", ".glb", (".glb",),
           "gltf:read_gltf", "gltf_write:write_gltf", magic=(b"glTF",),
           writer_args=(("binary_container", True),), drop=False, write_bytes=(90, 10)),
    Format("gltf", "glTF", "KHR_gaussian_splatting glTF with embedded buffers", ".gltf", (".gltf",),
           "gltf:read_gltf", "gltf_write:write_gltf", writer_args=(("binary_container", False),),
           drop=False, write_bytes=(300, 24)),
    # XGRIDS scanners' scenes: a JSON meta file beside its data files (lcc.py, lcc2.py), read
    # only, one level of detail (the finest unless `lod` says); z up as splat-transform reads them
    Format("lcc", "XGRIDS LCC", "LixelKity / Lixel CyberColor scene (meta.lcc with data.bin)",
           ".lcc (an XGRIDS scene's meta file)", (".lcc",), "lcc:read_lcc", axes=AXES_RFU,
           read_options=("lod",), levels="lcc:level_counts"),
    Format("lcc2", "XGRIDS LCC2", "XGRIDS octree scene of SOG or SPZ chunks",
           ".lcc2", (".lcc2",), "lcc2:read_lcc2", axes=AXES_RFU,
           read_options=("lod",), levels="lcc2:level_counts"),
]


def rows(writable: bool = False) -> tuple[Format, ...]:
    return tuple(r for r in ROWS if r.writer is not None or not writable)


def row(name: str) -> Format | None:
    return next((r for r in ROWS if r.name == name), None)


def by_magic(head: bytes) -> Format | None:
    return next((r for r in ROWS if r.matches(head)), None)


def by_name(path) -> Format | None:
    """The row a path's name picks: a whole file name, then a dotted suffix (".compressed.ply"),
    then the extension (the first row holding it: ".ply" is the float PLY)."""
    lower = os.fspath(path).lower()
    base, ext = os.path.basename(lower), os.path.splitext(lower)[1]
    return (next((r for r in ROWS if base in r.file_names), None)
            or next((r for r in ROWS for e in r.extensions if e.count(".") > 1 and lower.endswith(e)), None)
            or next((r for r in ROWS if ext and ext in r.extensions), None))


@contextlib.contextmanager
def registered(fmt: Format):
    """Add a row for the duration of the block (tests: a throwaway format), then remove it."""
    if row(fmt.name) is not None:
        raise ValueError(f"format {fmt.name!r} is already in the table")
    ROWS.append(fmt)
    try:
        yield fmt
    finally:
        ROWS.remove(fmt)


# What the user-facing lists say, built from the rows.

def suffixes(fmts) -> list[str]:
    """Each row's extensions by their last dot (".compressed.ply" is a ".ply"), once, in order."""
    seen = []
    for r in fmts:
        for e in r.extensions:
            e = e[e.rindex("."):]
            if e not in seen:
                seen.append(e)
    return seen


def file_glob(fmts, with_names: bool = True) -> str:
    """A file browser filter: "*.ply;*.splat;...;meta.json"."""
    parts = []
    for r in fmts:
        parts += [g for g in [f"*{e}" for e in suffixes([r])] + list(r.file_names if with_names else ())
                  if g not in parts]
    return ";".join(parts)


def menu_label(fmts) -> str:
    return f"Gaussian Splats ({', '.join(suffixes(fmts))})"


def readable_help() -> str:
    """'.ply, compressed .ply, ..., .glb or .gltf' for the command line's help texts."""
    names = [r.help for r in ROWS]
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} or {names[-1]}"
