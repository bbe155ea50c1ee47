"""GaussianSplats3D .ksplat (mkkellogg's SplatBuffer), version 0.1+, little endian:
  a 4096-byte header: u8 major 0, u8 minor >= 1, u32[1] section slots, u32[4] splat count,
  u16[10] compression level 0-2, f32[9..10] the SH range of level 2 (0: -1.5 .. 1.5);
  one 1024-byte header per section slot: u32[0] splats, u32[1] slots for splats, u32[2]
  bucket size, u32[3] bucket count, f32[4] bucket block size, u16[10] bytes per bucket,
  u32[6] position range (0: 32767), u32[8] full buckets, u32[9] partial buckets, u16[20] SH degree;
  then each section: partial bucket lengths (u32), bucket centres (3 f32), and its splat slots:
  position (level 0 f32; else u16 q: (q - range) * block / 2 / range + the bucket's centre),
  linear scale and rotation w x y z (f32 at level 0, else f16), u8 RGBA (colour = 0.5 + C0 dc,
  alpha = opacity), then the SH rest (f32, f16, or u8 over the header's range at level 2)
  band by band, each band channel-major (R's coefficients, G's, B's).
Axis convention: that of the PLY it was made from (RDF), as splat-transform reads it.
"""
from __future__ import annotations

import numpy as np

from ..errors import SplatFormatError
from ..sh import C0
from ..splats import AXES_RDF, SplatSet
from ._common import check_budget, normalize_quats_
from .readfile import OpenedFile

HEADER, SECTION_HEADER = 4096, 1024
FLOAT = {0: "<f4", 1: "<f2", 2: "<f2"}  # positions use u16 above level 0
SH_TYPE = {0: "<f4", 1: "<f2", 2: "u1"}
SH_COMPONENTS = {0: 0, 1: 9, 2: 24}


def _record(level: int, degree: int) -> np.dtype:
    pos = "<f4" if level == 0 else "<u2"
    fields = [("position", pos, 3), ("scale", FLOAT[level], 3), ("rot", FLOAT[level], 4), ("rgba", "u1", 4)]
    if degree:
        fields.append(("sh", SH_TYPE[level], SH_COMPONENTS[degree]))
    return np.dtype(fields)


def _header(path, f: OpenedFile):
    head = f.read_at(0, HEADER)
    if len(head) < HEADER:
        raise SplatFormatError(path, f"truncated .ksplat header: {len(head)} of {HEADER} bytes")
    major, minor = head[0], head[1]
    if major != 0 or minor < 1:
        raise SplatFormatError(path, f"unsupported .ksplat version {major}.{minor} (0.1 and later 0.x are read)")
    u32 = np.frombuffer(head, "<u4", 16)
    level = int(np.frombuffer(head, "<u2", 16)[10])
    if level > 2:
        raise SplatFormatError(path, f"unknown .ksplat compression level {level} (0-2 are read)")
    sh_min, sh_max = (float(v) for v in np.frombuffer(head, "<f4", 16)[9:11])
    return int(u32[1]), int(u32[4]), level, (sh_min or -1.5), (sh_max or 1.5)


def _sections(path, f: OpenedFile, slots: int, level: int) -> list[dict]:
    if HEADER + slots * SECTION_HEADER > f.size:
        raise SplatFormatError(path, f"{slots} section headers run past the end of the file ({f.size} bytes)")
    raw = f.read_exact(HEADER, slots * SECTION_HEADER)
    base, out = HEADER + slots * SECTION_HEADER, []
    for i in range(slots):
        block = bytes(raw[i * SECTION_HEADER:(i + 1) * SECTION_HEADER])
        u32, u16 = np.frombuffer(block, "<u4", 10), np.frombuffer(block, "<u2", 21)
        degree = int(u16[20])
        if degree not in SH_COMPONENTS:
            raise SplatFormatError(path, f"section {i}: SH degree {degree} (0-2 are read)")
        s = dict(count=int(u32[0]), slots=int(u32[1]), bucket_size=int(u32[2]), buckets=int(u32[3]),
                 block=float(np.frombuffer(block, "<f4", 5)[4]), bucket_bytes=int(u16[10]),
                 range=int(u32[6]) or 32767, full=int(u32[8]), partial=int(u32[9]), degree=degree)
        if s["count"] > s["slots"]:
            raise SplatFormatError(path, f"section {i}: {s['count']} splats in {s['slots']} slots")
        meta = 4 * s["partial"]
        s["base"], s["centres"] = base, base + meta
        s["data"] = base + meta + s["bucket_bytes"] * s["buckets"]
        s["record"] = _record(level, degree)
        base = s["data"] + s["record"].itemsize * s["slots"]
        if base > f.size:
            raise SplatFormatError(path, f"section {i} runs to byte {base}, past the end of the file ({f.size} bytes)")
        out.append(s)
    return out


def _bucket_of(path, f: OpenedFile, s: dict, i: int) -> np.ndarray:
    """Each splat's bucket: full buckets of bucket_size, then the partial ones by their lengths."""
    if s["bucket_bytes"] < 12 or s["full"] + s["partial"] > s["buckets"]:
        raise SplatFormatError(path, f"section {i}: bucket layout {s['full']}+{s['partial']} of "
                                     f"{s['buckets']} buckets, {s['bucket_bytes']} bytes each, is inconsistent")
    lengths = f.read_array("<u4", s["partial"], s["base"]).astype(np.int64)
    sizes = np.concatenate([np.full(s["full"], s["bucket_size"], np.int64), lengths])
    if sizes.sum() < s["count"]:
        raise SplatFormatError(path, f"section {i}: buckets hold {int(sizes.sum())} splats, fewer than its {s['count']}")
    # by search, not np.repeat: a hostile bucket size must not size an array
    return np.searchsorted(np.cumsum(sizes), np.arange(s["count"]), side="right")


def _rest(sh: np.ndarray, degree: int) -> np.ndarray:
    """Band-major, channel-major within a band -> (N, K, 3) coefficient-major."""
    parts, at = [], 0
    for band in range(1, degree + 1):
        k = 2 * band + 1
        parts.append(sh[:, at:at + 3 * k].reshape(-1, 3, k).transpose(0, 2, 1))
        at += 3 * k
    return np.concatenate(parts, axis=1)


def read_ksplat(path, max_degree: int = 3, max_splats=None) -> SplatSet:
    with OpenedFile(path) as f:
        slots, total, level, sh_min, sh_max = _header(path, f)
        sections = _sections(path, f, slots, level)
        counted = sum(s["count"] for s in sections)
        if counted != total:
            raise SplatFormatError(path, f"header says {total} splats, its sections hold {counted}")
        degree = max((s["degree"] for s in sections if s["count"]), default=0)
        keep = min(degree, max_degree)
        check_budget(path, total, SH_COMPONENTS[keep], max_splats)
        parts = [_section(path, f, s, i, level, keep, (sh_min, sh_max)) for i, s in enumerate(sections) if s["count"]]
        f.check_unchanged()
    if not parts:
        raise SplatFormatError(path, "holds no splats")
    out = SplatSet.allocate(0, 0, AXES_RDF)
    for name in ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest"):
        setattr(out, name, np.ascontiguousarray(np.concatenate([p[name] for p in parts])))
    return out


def _section(path, f: OpenedFile, s: dict, i: int, level: int, keep: int, sh_range) -> dict:
    rec = f.read_array(s["record"], s["count"], s["data"])
    if level == 0:
        positions = rec["position"].astype(np.float32)
    else:
        bucket = _bucket_of(path, f, s, i)
        centres = f.read_array("<f4", 3 * s["buckets"], s["centres"]).reshape(-1, 3)
        step = np.float32(s["block"] / 2.0 / s["range"])
        positions = (rec["position"].astype(np.float32) - np.float32(s["range"])) * step + centres[bucket]
    rgba = rec["rgba"].astype(np.float32) / np.float32(255.0)
    n_rest = SH_COMPONENTS[keep] // 3
    rest = np.zeros((s["count"], n_rest, 3), np.float32)
    have = min(keep, s["degree"])
    if have:
        sh = rec["sh"][:, :SH_COMPONENTS[have]].astype(np.float32)
        if level == 2:
            sh = np.float32(sh_range[0]) + sh / np.float32(255.0) * np.float32(sh_range[1] - sh_range[0])
        rest[:, :SH_COMPONENTS[have] // 3] = _rest(sh, have)
    return dict(positions=positions, scales=rec["scale"].astype(np.float32),
                rotations=normalize_quats_(rec["rot"].astype(np.float32)),
                opacities=rgba[:, 3].copy(), sh_dc=(rgba[:, :3] - np.float32(0.5)) / np.float32(C0), sh_rest=rest)
