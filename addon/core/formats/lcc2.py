"""XGRIDS LCC2: a `.lcc2` JSON meta file (often meta.lcc2) over an octree whose nodes' splats
sit in SOG (`.sog`, the default) or SPZ (`.spz`) chunk files beside it. One level of detail
is read: the finest (LOD 0) unless `lod` names another.

meta.lcc2, as PlayCanvas splat-transform 3.7.0's reader reads it (src/lib/readers/read-lcc2.ts):
  new protocol  totalLevels, totalSplats, lodSplats, splatType (".sog" or ".spz"),
                root {splatFiles: [chunk paths], child: [...] or {"0": ..., ...}}
  old protocol  total_splats, lod_3dgs_info, lod_level (all three), root.files (paths with
                a leading "/" and without ".sog", which old files always are)
  a node        data {"3dgs": {name: chunk index, start, count}, env: {name}}, child
A node at depth d below the root (its children are depth 1) holds LOD totalLevels - d: the
deepest nodes are LOD 0, the finest. A LOD's splats are its chunk files in ascending index
order, each file once (nodes of one level may share a file, each naming its rows), minus the
environment chunk (root.data.env, a skybox, left out as splat-transform's single-scene
conversions do). Trailing commas before } or ] are tolerated: some exporters write them.
The chunks' values are taken as they are stored: splat-transform reads them as LCC data,
Euler (90, 0, 180) like LCC, not in the SPZ or SOG frame, so the axes are RFU (lcc.py).
"""
from __future__ import annotations

import os
import re

import numpy as np

from ..errors import SplatFormatError
from ..splats import AXES_RFU, SplatSet, sh_coeff_count
from ._common import check_budget, json_object, level_index
from .readfile import read_whole

MAX_META = 64 << 20
_TRAILING = re.compile(r'"(?:\\.|[^"\\])*"|,(?=\s*[}\]])')


def read_lcc2(path, max_degree: int = 3, max_splats=None, lod=None) -> SplatSet:
    meta = _meta(path)
    levels = meta["levels"]
    lod = level_index(path, lod, levels)
    chunks = _chunks(path, meta, lod)
    known = [n for n in chunks.values() if n is not None]
    check_budget(path, sum(known), 3 * sh_coeff_count(max_degree), max_splats)
    parts = [_read_chunk(path, meta, index, count, max_degree, max_splats) for index, count in sorted(chunks.items())]
    return _concat(parts, max_degree)


def level_counts(path) -> list:
    """Splats per LOD, LOD 0 first, summed over the nodes' counts without decoding a chunk:
    None for a level where a node gives no count, 0 for a level with no chunks."""
    meta, out = _meta(path), []
    for lod in range(meta["levels"]):
        try:
            counts = list(_chunks(path, meta, lod).values())
        except SplatFormatError:  # no chunk at this level
            counts = [0]
        out.append(None if None in counts else sum(counts))
    return out


def _meta(path) -> dict:
    raw = read_whole(path, MAX_META)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise SplatFormatError(path, "meta.lcc2 is not UTF-8 text (not an LCC2 meta file)") from None
    try:
        doc = json_object(path, text, "meta.lcc2")
    except SplatFormatError:
        doc = json_object(path, _TRAILING.sub(lambda m: m.group(0) if m.group(0) != "," else "", text), "meta.lcc2")
    root = doc.get("root")
    if not isinstance(root, dict):
        raise SplatFormatError(path, "meta.lcc2 has no `root` node object")
    if all(k in doc for k in ("total_splats", "lod_3dgs_info", "lod_level")):
        levels, files = doc["lod_level"], root.get("files")
        if isinstance(files, list):
            files = [_old_name(f) for f in files]
    else:
        levels, files = doc.get("totalLevels"), root.get("splatFiles")
    if not isinstance(levels, int) or isinstance(levels, bool) or not 1 <= levels <= 64:
        raise SplatFormatError(path, f"meta.lcc2 LOD count {levels!r} is not an integer in 1..64")
    if not isinstance(files, list) or not all(isinstance(f, str) and f for f in files):
        raise SplatFormatError(path, "meta.lcc2 root must list its chunk files (splatFiles)")
    kind = doc.get("splatType", ".sog")
    if kind not in (".sog", ".spz"):
        raise SplatFormatError(path, f"unknown LCC2 splatType {kind!r} (known: '.sog', '.spz')")
    env = root.get("data", {}).get("env", {}) if isinstance(root.get("data"), dict) else {}
    return {"levels": levels, "files": files, "type": kind, "root": root,
            "env": env.get("name") if isinstance(env, dict) else None}


def _old_name(f):
    if not isinstance(f, str):
        return f
    f = f[1:] if f.startswith("/") else f
    return f if f.endswith(".sog") else f + ".sog"


def _children(node) -> list:
    c = node.get("child")
    kids = c if isinstance(c, list) else list(c.values()) if isinstance(c, dict) else []
    return [k for k in kids if isinstance(k, dict)]


def _chunks(path, meta, lod: int) -> dict:
    """{chunk index: splat count, or None where a node gives none} of the LOD's nodes."""
    out: dict = {}
    stack = [(child, 1) for child in _children(meta["root"])]
    while stack:
        node, depth = stack.pop()
        stack += [(child, depth + 1) for child in _children(node)]
        data = node.get("data")
        entry = data.get("3dgs") if isinstance(data, dict) else None
        if not isinstance(entry, dict) or meta["levels"] - depth != lod:
            continue
        index = entry.get("name")
        if index == meta["env"]:
            continue
        if not isinstance(index, int) or isinstance(index, bool) or not 0 <= index < len(meta["files"]):
            raise SplatFormatError(path, f"meta.lcc2 names chunk {index!r}; root lists {len(meta['files'])} files")
        count = entry.get("count")
        count = count if isinstance(count, int) and not isinstance(count, bool) and count >= 0 else None
        if index in out:
            out[index] = None if out[index] is None or count is None else out[index] + count
        else:
            out[index] = count
    if not out:
        raise SplatFormatError(path, f"meta.lcc2 has no chunks at LOD {lod}")
    return out


def _chunk_path(path, meta, index: int) -> str:
    name = meta["files"][index]
    parts = name.replace("\\", "/").split("/")
    if os.path.isabs(name) or ".." in parts or "\0" in name:
        raise SplatFormatError(path, f"meta.lcc2 chunk {name!r} is not a path inside its folder")
    full = os.path.join(os.path.dirname(os.fspath(path)), *parts)
    if not os.path.exists(full):  # as splat-transform: a path that is missing, then its bare name
        bare = os.path.join(os.path.dirname(os.fspath(path)), parts[-1])
        if os.path.exists(bare):
            return bare
        raise SplatFormatError(path, f"chunk file {name!r} is missing (looked for {full})")
    return full


def _read_chunk(path, meta, index, count, max_degree, max_splats) -> SplatSet:
    from .sog import read_sog
    from .spz import read_spz
    full = _chunk_path(path, meta, index)
    reader = read_spz if meta["type"] == ".spz" else read_sog
    splats = reader(full, max_degree, max_splats)
    if count is not None and splats.count != count:
        raise SplatFormatError(full, f"holds {splats.count} splats; meta.lcc2 says {count}")
    return splats


def _concat(parts, max_degree) -> SplatSet:
    """One set in the chunks' order; a chunk with fewer SH bands is padded with zeros."""
    degree = min(max_degree, max(p.sh_degree for p in parts))
    k = sh_coeff_count(degree)
    rest = []
    for p in parts:
        r = p.sh_rest[:, :k]
        if r.shape[1] < k:
            r = np.concatenate([r, np.zeros((p.count, k - r.shape[1], 3), np.float32)], 1)
        rest.append(r)
    in_file = max(p.sh_degree if p.sh_degree_in_file is None else p.sh_degree_in_file for p in parts)
    return SplatSet(
        positions=np.concatenate([p.positions for p in parts]),
        scales=np.concatenate([p.scales for p in parts]),
        rotations=np.concatenate([p.rotations for p in parts]),
        opacities=np.concatenate([p.opacities for p in parts]),
        sh_dc=np.concatenate([p.sh_dc for p in parts]),
        sh_rest=np.concatenate(rest), axes=AXES_RFU,
        sh_degree_in_file=in_file if in_file != degree else None,
        antialiased=all(p.antialiased for p in parts))
