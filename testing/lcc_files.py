"""XGRIDS LCC and LCC2 scenes written for tests and benches: no LCC writer is installable, so
this is Splatline's own, to the layout splat-transform 3.7.0's readers decode (facts in
addon/core/formats/lcc.py and lcc2.py). The splats are written as they are given (their
values, not their `axes`: LCC data is RFU). Every LOD is one SplatSet, LOD 0 first.

`lcc_steps` gives the quantisation's half-steps, the bound a decoded scene keeps to its source.
"""
from __future__ import annotations

import json
import os
import re
from dataclasses import replace

import numpy as np

from addon.core.formats import write
from addon.core.sh import C0
from addon.core.splats import AXES_RDF, AXES_RUB

SQRT2 = np.sqrt(2.0)


def bounds(values: np.ndarray) -> np.ndarray:
    """(2, 3) min and max per column, widened where a column is constant (no zero span)."""
    lo, hi = values.min(0).astype(np.float64), values.max(0).astype(np.float64)
    return np.stack([lo, np.where(hi > lo, hi, lo + 1.0)])


def _quantise(values, b, bits):
    top = (1 << bits) - 1
    return np.clip(np.rint((values - b[0]) / (b[1] - b[0]) * top), 0, top).astype(np.uint32)


def encode_rotations(wxyz: np.ndarray) -> np.ndarray:
    """u32: three 10-bit components of (x, y, z, w) without the largest, its index in 30-31."""
    q = np.asarray(wxyz, np.float64)[:, [1, 2, 3, 0]]
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    k = np.abs(q).argmax(1)
    q *= np.where(q[np.arange(len(q)), k] < 0, -1.0, 1.0)[:, None]
    out = k.astype(np.uint32) << 30
    for i, slot in enumerate(np.array([[c for c in range(4) if c != j] for j in range(4)])[k].T):
        c = q[np.arange(len(q)), slot]
        out |= np.clip(np.rint((c + 1 / SQRT2) / SQRT2 * 1023), 0, 1023).astype(np.uint32) << (10 * i)
    return out


def encode_records(s, scale_b) -> np.ndarray:
    rec = np.zeros((s.count, 32), np.uint8)
    rec[:, 0:12] = np.ascontiguousarray(s.positions, "<f4").view(np.uint8).reshape(-1, 12)
    rgba = np.concatenate([s.sh_dc * C0 + 0.5, s.opacities[:, None]], 1)
    rec[:, 12:16] = np.clip(np.rint(rgba * 255), 0, 255).astype(np.uint8)
    half = np.zeros((s.count, 8), "<u2")
    half[:, 0:3] = np.stack([_quantise(s.scales[:, a], scale_b[:, a], 16) for a in range(3)], 1)
    rot = encode_rotations(s.rotations)
    half[:, 3], half[:, 4] = rot & 0xFFFF, rot >> 16
    rec[:, 16:32] = half.view(np.uint8).reshape(-1, 16)
    return rec


def rest15(s) -> np.ndarray:
    """(N, 15, 3): the degree-3 bands LCC stores, zero past the set's own."""
    out = np.zeros((s.count, 15, 3), np.float32)
    out[:, :s.sh_rest.shape[1]] = s.sh_rest[:, :15]
    return out


def encode_sh(s, sh_b) -> np.ndarray:
    enc = np.zeros((s.count, 16), "<u4")
    rest = rest15(s)
    for c, (shift, bits) in enumerate(((0, 11), (11, 10), (21, 11))):
        enc[:, :15] |= _quantise(rest[:, :, c], sh_b[:, c], bits) << shift
    return enc.view(np.uint8)


def write_lcc(folder, lods, sh: bool = True, units: int = 3, name: str = "meta.lcc", **meta_fields) -> str:
    """meta.lcc, index.bin, data.bin (and shcoef.bin with sh) in `folder`; each LOD's splats
    split over `units` quadtree cells. meta_fields override or add meta.lcc entries."""
    os.makedirs(folder, exist_ok=True)
    every = np.concatenate([s.scales for s in lods])
    scale_b = bounds(every)
    rest = np.concatenate([rest15(s).reshape(-1, 3) for s in lods]) if sh else np.zeros((1, 3))
    sh_b = bounds(rest)
    data, shdata, index, offset = [], [], [], 0
    for u in range(units):
        entry = [np.array([u, -u], "<i2").tobytes()]
        for s in lods:
            part = s.subset(np.array_split(np.arange(s.count), units)[u])
            rec = encode_records(part, scale_b)
            entry.append(np.array([part.count], "<i4").tobytes() + np.array([offset], "<i8").tobytes()
                         + np.array([rec.nbytes], "<i4").tobytes())
            data.append(rec.tobytes())
            if sh:
                shdata.append(encode_sh(part, sh_b).tobytes())
            offset += rec.nbytes
        index.append(b"".join(entry))
    meta = {"version": "5.0", "name": "Splatline test scene", "totalSplats": sum(s.count for s in lods),
            "totalLevel": len(lods), "splats": [s.count for s in lods], "encoding": "COMPRESS",
            "fileType": "Quality" if sh else "Portable", "indexDataSize": 4 + 16 * len(lods),
            "attributes": [{"name": "scale", "min": list(scale_b[0]), "max": list(scale_b[1])},
                           {"name": "shcoef", "min": list(sh_b[0]), "max": list(sh_b[1])}]}
    meta.update(meta_fields)
    for file, parts in (("index.bin", index), ("data.bin", data)) + ((("shcoef.bin", shdata),) if sh else ()):
        with open(os.path.join(folder, file), "wb") as f:
            f.write(b"".join(parts))
    path = os.path.join(folder, name)
    with open(path, "w") as f:
        json.dump(meta, f)
    return path


def lcc_steps(path) -> dict:
    """Half the quantisation step of each stored quantity, from the scene's meta.lcc."""
    meta = json.load(open(path))
    named = {a["name"]: np.array([a["min"], a["max"]]) for a in meta["attributes"]}
    span = lambda n: named[n][1] - named[n][0]  # noqa: E731
    return {"scale": span("scale") / 65535 / 2, "colour": 1 / 255 / 2 / C0, "opacity": 1 / 255 / 2,
            "rotation": SQRT2 / 1023 / 2, "sh": span("shcoef") / np.array([2047, 1023, 2047]) / 2}


def write_lcc2(folder, lods, splat_type: str = ".spz", chunks: int = 2, old_protocol: bool = False,
               trailing_commas: bool = False, env=None, name: str = "meta.lcc2") -> str:
    """meta.lcc2 and its chunk files: each LOD split over `chunks` files, one octree node per
    file, the nodes of depth d (LOD = levels - d) children of the first node one level up.
    The last LOD-0 file is shared by two nodes (start/count), as real scenes may do. env: a
    SplatSet written as the environment chunk."""
    os.makedirs(folder, exist_ok=True)
    levels, files, by_depth = len(lods), [], []
    ext = ".sog" if old_protocol else splat_type
    for lod in range(levels - 1, -1, -1):
        nodes = []
        for part in np.array_split(np.arange(lods[lod].count), chunks):
            files.append(f"chunks/lod{lod}_{len(files)}{ext}")
            _write_chunk(os.path.join(folder, files[-1]), lods[lod].subset(part), ext)
            nodes.append({"data": {"3dgs": {"name": len(files) - 1, "start": 0, "count": int(len(part))}}})
        if lod == 0:  # two nodes share the last file, each naming its rows
            last = nodes[-1]["data"]["3dgs"]
            first = last["count"] // 2
            nodes.append({"data": {"3dgs": {"name": last["name"], "start": first, "count": last["count"] - first}}})
            last["count"] = first
        by_depth.append(nodes)
    for upper, lower in zip(by_depth, by_depth[1:]):
        upper[0]["child"] = {str(i): node for i, node in enumerate(lower)}
    root = {"child": by_depth[0], "data": {}}
    if env is not None:
        files.append(f"env{ext}")
        _write_chunk(os.path.join(folder, files[-1]), env, ext)
        root["data"]["env"] = {"name": len(files) - 1}
    counts = [s.count for s in lods]
    if old_protocol:
        root["files"] = ["/" + f[: -len(".sog")] for f in files]
        meta = {"total_splats": sum(counts), "lod_3dgs_info": counts[::-1], "lod_level": levels, "root": root}
    else:
        root["splatFiles"] = files
        meta = {"totalSplats": sum(counts), "lodSplats": counts, "totalLevels": levels,
                "splatType": splat_type, "root": root}
    text = json.dumps(meta, indent=1)
    if trailing_commas:
        text = re.sub(r"\n(\s*)([}\]])", r",\n\1\2", text)
    path = os.path.join(folder, name)
    with open(path, "w") as f:
        f.write(text)
    return path


def _write_chunk(path, splats, ext) -> None:
    """The chunk holds the values as given: labelled in the writer's own frame, nothing turns."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    write(path, replace(splats, axes=AXES_RUB if ext == ".spz" else AXES_RDF))
