"""PlayCanvas streamed SOG: `lod-meta.json` and its chunks, each chunk an unbundled SOG
(formats/sog.py) holding splats of one level of detail. splat-transform's LOD writer and
SuperSplat write it for scenes too large to load whole; a viewer streams the chunks.

lod-meta.json (facts from splat-transform 3.7's src/lib/readers/read-lod.ts and
writers/write-lod.ts, checked against its decodes: tests/core/formats/test_formats_streamed_sog.py):
  version     1, or absent in manifests written before it was stamped
  lodLevels   how many levels; level 0 is the finest (full detail), as the writer's
              `--tag-lod` numbers them
  counts      optional, splats per level; checked against the tree's references
  filenames   chunk paths relative to the manifest ("0_1/meta.json": level 0, its second chunk)
  tree        a spatial tree of nodes {bound, children?, lods?}; a leaf's lods map a level
              ("0") to {file, offset, count}: `count` splats of that level in filenames[file]
  environment optional SOG drawn at every level (env/meta.json); left out of a level's read,
              as splat-transform leaves it out of a single-scene output
A level is its chunk files, each whole, in ascending file index: the order splat-transform
decodes a level in (`-L N` to a single-scene output). A chunk must hold exactly the splats
the tree gives it, and every chunk the same SH degree.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

from .. import budget
from ..errors import SplatFormatError
from ..splats import AXES_RDF, SplatSet, sh_coeff_count
from ._common import check_budget, json_object
from .readfile import read_whole
from .sog import MAX_SPLATS, parse_meta, read_sog

FILE_NAME = "lod-meta.json"
MAX_MANIFEST = 256 << 20   # the tree of a 100M-splat scene is a few MB; more is not a manifest
MAX_LEVELS = 64


def is_lod_meta(path) -> bool:
    return os.path.basename(os.fspath(path)).lower() == FILE_NAME


@dataclass
class Manifest:
    path: str
    counts: list[int]                      # splats per level
    chunks: list[list[tuple[str, int]]]    # per level: (chunk path, splats), in file order
    environment: str | None = None

    def levels_text(self) -> str:
        return ", ".join(f"{lod} ({n:,} splats)" for lod, n in enumerate(self.counts))


def _int(value, lo: int, hi: int) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and lo <= value <= hi


def _chunk_name(path, name) -> str:
    """A chunk path that stays inside the manifest's folder: relative, no '..'."""
    parts = name.split("/") if isinstance(name, str) else []
    if not parts or any(p in ("", ".", "..") or "\\" in p or "\0" in p for p in parts):
        raise SplatFormatError(path, f"{FILE_NAME} filenames lists {name!r}, not a relative "
                                     "path inside its folder")
    return name


def _references(path, tree, levels: int, files: int) -> list[dict[int, int]]:
    """Per level, splats by file index, summed over every leaf of the tree (walked with a
    stack: a deep tree is no recursion limit)."""
    by_level: list[dict[int, int]] = [{} for _ in range(levels)]
    stack = [tree]
    while stack:
        node = stack.pop()
        children = node.get("children", []) if isinstance(node, dict) else None
        lods = node.get("lods", {}) if isinstance(node, dict) else None
        if not isinstance(children, list) or not isinstance(lods, dict):
            raise SplatFormatError(path, f"{FILE_NAME} tree holds a node that is not "
                                         "{children: [...], lods: {...}}")
        for key, ref in lods.items():
            lod = int(key) if isinstance(key, str) and key.isdigit() else -1
            ok = (0 <= lod < levels and isinstance(ref, dict) and _int(ref.get("file"), 0, files - 1)
                  and _int(ref.get("offset"), 0, MAX_SPLATS) and _int(ref.get("count"), 0, MAX_SPLATS))
            if not ok:
                raise SplatFormatError(path, f"{FILE_NAME} tree has a bad reference for level "
                                             f"{key!r}: {ref!r} (levels 0..{levels - 1}, files 0..{files - 1})")
            per_file = by_level[lod]
            per_file[ref["file"]] = per_file.get(ref["file"], 0) + ref["count"]
        stack.extend(children)
    return by_level


def read_manifest(path) -> Manifest:
    """The levels of a lod-meta.json and the chunks of each, checked; no chunk is read."""
    meta = json_object(path, bytes(read_whole(path, MAX_MANIFEST)), FILE_NAME)
    if meta.get("version", 1) != 1:
        raise SplatFormatError(path, f"unsupported {FILE_NAME} version {meta['version']!r} (supported: 1)")
    levels = meta.get("lodLevels")
    if not _int(levels, 1, MAX_LEVELS):
        raise SplatFormatError(path, f"{FILE_NAME} lodLevels must be an integer in 1..{MAX_LEVELS}, "
                                     f"not {levels!r}")
    names = meta.get("filenames")
    if not isinstance(names, list) or not names:
        raise SplatFormatError(path, f"{FILE_NAME} filenames must be a list of chunk paths")
    names = [_chunk_name(path, n) for n in names]
    if not isinstance(meta.get("tree"), dict):
        raise SplatFormatError(path, f"{FILE_NAME} has no tree object")
    by_level = _references(path, meta["tree"], levels, len(names))
    counts = [sum(files.values()) for files in by_level]
    stated = meta.get("counts")
    if stated is not None and stated != counts:
        raise SplatFormatError(path, f"{FILE_NAME} counts {stated!r} disagree with its tree "
                                     f"({counts})")
    folder = os.path.dirname(os.fspath(path))
    chunks = [[(os.path.join(folder, names[f]), n) for f, n in sorted(files.items())]
              for files in by_level]
    env = meta.get("environment")
    env = os.path.join(folder, _chunk_name(path, env)) if env is not None else None
    return Manifest(os.fspath(path), counts, chunks, env)


def level_for(manifest: Manifest, lod) -> int:
    """The level to read: `lod`, or the finest (0) for None; refused out of range."""
    lod = 0 if lod is None else lod
    if not _int(lod, 0, len(manifest.counts) - 1):
        raise SplatFormatError(manifest.path, f"has no level of detail {lod}; its levels: "
                                              f"{manifest.levels_text()}")
    return lod


def _rest_floats(manifest: Manifest, lod: int, max_degree: int) -> int:
    """Higher-SH floats a splat of the level will hold: from its first chunk's meta.json
    (a few KB), or the most a SOG holds where that is a bundled .sog."""
    first = manifest.chunks[lod][0][0] if manifest.chunks[lod] else None
    try:
        meta = _chunk_meta(first) if first else None
    except SplatFormatError as exc:
        raise SplatFormatError(exc.path, f"{exc.reason} (level {lod} of {manifest.path})") from None
    if meta is None:
        return 3 * sh_coeff_count(max_degree)
    shn = meta.get("shN")
    bands = shn.get("bands", 3) if isinstance(shn, dict) else 0
    return 3 * sh_coeff_count(min(bands if _int(bands, 0, 3) else 3, max_degree))


def _check_budget(manifest: Manifest, lod: int, max_degree: int, max_splats) -> None:
    """The level must fit the budget; a refusal names the finest level that does."""
    rest = _rest_floats(manifest, lod, max_degree)
    try:
        check_budget(manifest.path, manifest.counts[lod], rest, max_splats)
    except SplatFormatError as exc:
        fits = next((k for k in range(lod + 1, len(manifest.counts))
                     if _fits(manifest, k, rest, max_splats)), None)
        hint = (f"; level {fits} ({manifest.counts[fits]:,} splats) fits: --lod {fits}" if fits is not None
                else "; no coarser level fits either")
        kind = type(exc) if isinstance(exc, budget.BudgetError) else SplatFormatError
        raise kind(manifest.path, f"level {lod} {exc.reason}{hint}") from None


def _fits(manifest: Manifest, lod: int, rest: int, max_splats) -> bool:
    try:
        check_budget(manifest.path, manifest.counts[lod], rest, max_splats)
    except SplatFormatError:
        return False
    return True


def read_streamed_sog(path, max_degree: int = 3, max_splats=None, lod=None) -> SplatSet:
    manifest = read_manifest(path)
    lod = level_for(manifest, lod)
    _check_budget(manifest, lod, max_degree, max_splats)
    chunks = manifest.chunks[lod]
    out, start, degree_in_file = None, 0, None
    for i, (chunk, count) in enumerate(chunks):
        where = f"chunk {i + 1} of {len(chunks)} of level {lod} of {manifest.path}"
        try:  # a chunk claiming other than the tree gives it is refused before it is decoded
            meta = _chunk_meta(chunk)
            claimed = None if meta is None else meta["count"]
            if claimed not in (None, count):
                raise SplatFormatError(chunk, f"holds {claimed} splats, the tree gives it {count}")
            part = read_sog(chunk, max_degree, max_splats=count)
        except SplatFormatError as exc:
            raise SplatFormatError(exc.path, f"{exc.reason} ({where})") from None
        if part.count != count:
            raise SplatFormatError(chunk, f"holds {part.count} splats, the tree gives it {count} ({where})")
        if out is None:  # the whole level at once: one chunk decoded beside it at a time
            out = SplatSet.allocate(manifest.counts[lod], part.sh_degree, AXES_RDF)
            degree_in_file = part.sh_degree_in_file
        elif part.sh_degree_in_file != degree_in_file:
            raise SplatFormatError(chunk, f"holds SH degree {part.sh_degree_in_file}, its level's "
                                          f"first chunk {degree_in_file} ({where})")
        _place(out, part, start)
        start += count
    if out is None:  # a level the tree lists with no splats
        out = SplatSet.allocate(0, 0, AXES_RDF)
    out.sh_degree_in_file = degree_in_file or 0
    return out


def _chunk_meta(chunk) -> dict | None:
    """An unbundled chunk's meta.json, checked (a few KB read); None for a bundled .sog,
    whose count read_sog checks against the tree's as a splat budget."""
    if os.path.basename(chunk).lower() != "meta.json":
        return None
    return parse_meta(chunk, bytes(read_whole(chunk, 1 << 20)))


def _place(out: SplatSet, part: SplatSet, start: int) -> None:
    rows = slice(start, start + part.count)
    for name in ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest"):
        getattr(out, name)[rows] = getattr(part, name)


def level_counts(path) -> list[int]:
    """Splats per level of a lod-meta.json, finest first (info lists them)."""
    return read_manifest(path).counts

