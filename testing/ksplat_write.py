"""A .ksplat writer for tests, from GaussianSplats3D's published layout (the facts in
addon/core/formats/ksplat.py's docstring): Splatline reads the format but does not write it.

Splats go into `sections` consecutive sections; in each, consecutive runs of `bucket_size`
splats are the full buckets and what is left is one partial bucket (GaussianSplats3D groups by
space, but a reader only sees bucket centres and lengths). Each bucket's centre is the middle
of its splats' box; the block size is the largest box side in the section, so every offset
fits the u16 range. Quantisation rounds to nearest, so a decode is within half a step.
"""
from __future__ import annotations

import numpy as np

from addon.core.formats.ksplat import HEADER, SECTION_HEADER, SH_COMPONENTS, _record
from addon.core.sh import C0

POSITION_RANGE = 32767


def _sh_layout(rest: np.ndarray, degree: int) -> np.ndarray:
    """(N, K, 3) coefficient-major -> band by band, channel-major within a band."""
    parts, at = [], 0
    for band in range(1, degree + 1):
        k = 2 * band + 1
        parts.append(rest[:, at:at + k].transpose(0, 2, 1).reshape(len(rest), 3 * k))
        at += k
    return np.concatenate(parts, axis=1) if parts else np.zeros((len(rest), 0), np.float32)


def _u8(x) -> np.ndarray:
    return np.clip(np.rint(x), 0, 255).astype(np.uint8)


def _section(splats, lo, hi, level, degree, bucket_size, sh_range):
    n = hi - lo
    pos = splats.positions[lo:hi].astype(np.float64)
    rec = np.zeros(n, _record(level, degree))
    full, rest_len = divmod(n, bucket_size)
    lengths = [bucket_size] * full + ([rest_len] if rest_len else [])
    centres, block, bucket = np.zeros((len(lengths), 3)), 0.0, np.repeat(np.arange(len(lengths)), lengths)
    if level:
        at = 0
        for b, k in enumerate(lengths):
            box = pos[at:at + k]
            centres[b] = (box.min(0) + box.max(0)) / 2
            block = max(block, float((box.max(0) - box.min(0)).max()))
            at += k
        block = max(block, 1e-6) * 1.001
        centres = centres.astype(np.float32)
        step = block / 2 / POSITION_RANGE
        q = np.rint((pos - centres[bucket].astype(np.float64)) / step) + POSITION_RANGE
        rec["position"] = np.clip(q, 0, 2 * POSITION_RANGE)
    else:
        rec["position"] = pos
    rec["scale"] = splats.scales[lo:hi]
    rec["rot"] = splats.rotations[lo:hi]
    rec["rgba"][:, :3] = _u8((0.5 + C0 * splats.sh_dc[lo:hi].astype(np.float64)) * 255)
    rec["rgba"][:, 3] = _u8(splats.opacities[lo:hi].astype(np.float64) * 255)
    if degree:
        sh = _sh_layout(splats.sh_rest[lo:hi, :SH_COMPONENTS[degree] // 3].astype(np.float64), degree)
        if level == 2:
            sh = _u8((np.clip(sh, *sh_range) - sh_range[0]) / (sh_range[1] - sh_range[0]) * 255)
        rec["sh"] = sh
    head = np.zeros(SECTION_HEADER, np.uint8)
    u32, u16, f32 = head.view("<u4"), head.view("<u2"), head.view("<f4")
    u32[0] = u32[1] = n
    if level:
        u32[2], u32[3], f32[4], u16[10] = bucket_size, len(lengths), block, 12
        u32[6], u32[8], u32[9] = POSITION_RANGE, full, 1 if rest_len else 0
    u16[20] = degree
    partial = np.array([rest_len] if (level and rest_len) else [], "<u4")
    body = partial.tobytes() + (centres.astype("<f4").tobytes() if level else b"") + rec.tobytes()
    return head.tobytes(), body


def write_ksplat(path, splats, level: int = 0, degree: int = 0, sections: int = 1,
                 bucket_size: int = 256, sh_range=(-1.5, 1.5), version=(0, 1)) -> None:
    """Write `splats` (RDF) as a .ksplat at compression `level` holding SH up to `degree`."""
    bounds = np.linspace(0, splats.count, sections + 1).astype(int)
    heads, bodies = [], []
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        h, b = _section(splats, lo, hi, level, degree, bucket_size, sh_range)
        heads.append(h)
        bodies.append(b)
    head = np.zeros(HEADER, np.uint8)
    head[0], head[1] = version
    u32, u16, f32 = head.view("<u4"), head.view("<u2"), head.view("<f4")
    u32[1] = u32[2] = sections
    u32[3] = u32[4] = splats.count
    u16[10] = level
    f32[9], f32[10] = sh_range
    with open(path, "wb") as f:
        f.write(head.tobytes() + b"".join(heads) + b"".join(bodies))
