"""Writing a capture as Avala AI's .4dgs (version 1, "gaussian-birth"; layout in fourdgs.py).

The quantisation is the format's "uniform-v1" with fourdgs' profiles: every grid pitch is
twice its error bound, the position bound a fraction of the median scale (fine 0.02,
default 0.05, coarse 0.2). Splats keep the capture's order (fourdgs' own writer sorts them
by lifetime and Morton code): consecutive chunks of at most CHUNK_SPLATS, each covering the
whole timeline [0, duration], each followed by its SH band records, then the Chunk Index,
the Footer with the index's CRC-32, and the closing magic.

Held: centres, linear motion, fixed rotations, linear scales, colour and opacity, mu_t,
sigma_t (+inf never fades), validity windows (float64, exact), the cut-off, SH up to degree
3 (each coefficient a byte over [-4, 4]). Refused: cubic motion and omega (convert.to_fourdgs
says so), a capture in segment units (convert with to_fourdgs(capture, seconds_per_unit)),
non-finite values other than sigma_t = +inf and infinite windows. Lost: the capture's
t_start (a .4dgs timeline starts at 0) and precision to the profile's bounds.
"""
from __future__ import annotations

import math
import struct
import zlib

import numpy as np

from ..errors import SplatFormatError
from ..formats._common import write_file
from ..sh import C0
from . import fourdgs_wire as wire
from .capture import DynamicCapture
from .convert import to_fourdgs
from .fourdgs import (COLOR, FLAGS, MOTION, MU_T, OPACITY, POSITION, ROTATION, ROTATION_INDEX, SCALE, SH_BANDS,
                      SH_QUANT_HI, SH_QUANT_LO, SIGMA_T, STEP_NAMES, WINDOW_INDEX, life_class, motion_steps,
                      mu_steps, support_k)

CHUNK_SPLATS = 1 << 20  # fourdgs refuses a stream that decodes past 512 MiB of int64
# profile -> (position bound / median scale, relative scale and sigma bound, rotation, colour x 255, time)
PROFILES = {"fine": (0.02, 0.005, 0.0005, 0.5, 0.0005), "default": (0.05, 0.02, 0.002, 1.0, 0.002),
            "coarse": (0.20, 0.06, 0.006, 3.0, 0.008)}
LIFE_REF = 0.5
DEFAULT_LEVEL = {"deflate": 1, "zstd": 3}


def _steps(profile: str, median_scale: float) -> tuple[dict, dict]:
    pos_k, rel, rot, colour, time = PROFILES[profile]
    bounds = dict(pos=pos_k * median_scale, scale_rel=rel, rot=rot, rgb=colour / 255.0, alpha=colour / 255.0,
                  motion=pos_k * median_scale / LIFE_REF, time=time, sigma_rel=rel, sh=0)
    steps = dict(pos=2 * bounds["pos"], scale_log=2 * math.log1p(rel), rot=2 * rot, rgb=2 * bounds["rgb"],
                 alpha=2 * bounds["alpha"], motion=2 * bounds["motion"], time=2 * time,
                 sigma_log=2 * math.log1p(rel))
    return bounds, steps


def _as_fourdgs(path, capture: DynamicCapture) -> DynamicCapture:
    if capture.model != "4dgs":
        if capture.unit != "seconds":
            raise SplatFormatError(path, "a capture in segment units has no seconds for .4dgs: convert it with "
                                         "core.dynamic.to_fourdgs(capture, seconds_per_unit) first")
        try:
            capture = to_fourdgs(capture)
        except SplatFormatError as exc:
            raise SplatFormatError(path, exc.reason) from None
    if capture.segments != 1:
        raise SplatFormatError(path, f"a .4dgs holds one capture; this one has {capture.segments} segments")
    if not (math.isfinite(capture.t_end) and capture.t_end >= 0):
        raise SplatFormatError(path, f"the capture ends at {capture.t_end}; a .4dgs duration is finite and >= 0")
    return capture


def _check_finite(path, fields: dict) -> None:
    for name, values in fields.items():
        bad = ~np.isfinite(values).reshape(len(values), -1 if values.size else 0).all(axis=1)
        if bad.any():
            raise SplatFormatError(path, f"{int(bad.sum())} splats have a non-finite {name}, which .4dgs cannot hold")


def _quantise(path, c: DynamicCapture, steps: dict, origin) -> tuple[dict, np.ndarray]:
    """({attribute: int64 symbols} in capture order, the Window Table)."""
    f64 = np.float64
    sigma = c.t_scale.astype(f64)
    window = c.window if c.window is not None else np.tile([-np.inf, np.inf], (c.count, 1))
    _check_finite(path, {"centre": c.positions, "scale": c.scales, "rotation": c.rotations, "colour": c.sh_dc,
                         "opacity": c.opacities, "motion": c.motion, "time centre": c.t_center})
    if (np.isnan(sigma) | (sigma < 0)).any() or np.isnan(window).any():
        raise SplatFormatError(path, "a NaN or negative sigma_t, or a NaN validity window, which .4dgs cannot hold")
    never = ~np.isfinite(sigma)
    q_sigma = np.rint(np.log(np.maximum(np.where(never, 1.0, sigma), 1e-30)) / steps["sigma_log"])
    q_sigma[never] = 0
    table, win_index = np.unique(window.astype(f64), axis=0, return_inverse=True)
    with np.errstate(invalid="ignore"):
        length = (table[:, 1] - table[:, 0])[win_index.reshape(-1)]
    m_step = motion_steps(life_class(q_sigma, steps["sigma_log"], never, length, support_k(c.cutoff)),
                          steps["motion"])
    t_step = mu_steps(q_sigma, steps["sigma_log"], never, steps["time"])
    rgb = np.clip(C0 * c.sh_dc.astype(f64) + 0.5, 0.0, 1.0)
    q_rgb = np.rint(rgb / steps["rgb"])
    largest, q_rot = _smallest_three(c.rotations, steps["rot"])
    symbols = {
        POSITION: np.rint((c.positions - origin) / steps["pos"]),
        SCALE: np.rint(np.log(np.maximum(c.scales.astype(f64), 1e-30)) / steps["scale_log"]),
        ROTATION_INDEX: largest, ROTATION: q_rot,
        COLOR: np.stack([q_rgb[:, 1], q_rgb[:, 0] - q_rgb[:, 1], q_rgb[:, 2] - q_rgb[:, 1]], axis=1),
        OPACITY: np.rint(np.clip(c.opacities.astype(f64), 0.0, 1.0) / steps["alpha"]),
        MOTION: np.rint(c.motion[:, 0].astype(f64) / m_step[:, None]),
        MU_T: np.rint(c.t_center.astype(f64) / t_step), SIGMA_T: q_sigma, FLAGS: never,
        WINDOW_INDEX: win_index.reshape(-1),
    }
    for ident, values in symbols.items():
        if np.abs(values).max(initial=0) >= 2.0 ** 31:
            raise SplatFormatError(path, f"attribute {ident} needs more than 32-bit symbols at this quantisation")
    return {ident: values.astype(np.int64) for ident, values in symbols.items()}, table


def _smallest_three(wxyz, step) -> tuple[np.ndarray, np.ndarray]:
    """xyzw with its largest component left out, the sign made positive."""
    q = wxyz.astype(np.float64)[:, [1, 2, 3, 0]]
    q /= np.maximum(np.linalg.norm(q, axis=1, keepdims=True), 1e-30)
    largest = np.argmax(np.abs(q), axis=1)
    rows = np.arange(len(q))
    q *= np.where(q[rows, largest] < 0, -1.0, 1.0)[:, None]
    others = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])[largest]
    return largest, np.rint(np.take_along_axis(q, others, axis=1) / step)


def _sh_bytes(c: DynamicCapture) -> dict:
    """band -> (N, 3 (2 band + 1)) coefficient bytes, red's, green's, blue's."""
    out = {}
    for band in range(1, c.sh_degree + 1):
        first, last = SH_BANDS[band]
        coeff = c.sh_rest[:, first:last].astype(np.float64).transpose(0, 2, 1).reshape(c.count, 3 * (last - first))
        out[band] = np.clip(np.rint((coeff - SH_QUANT_LO) / (SH_QUANT_HI - SH_QUANT_LO) * 255.0), 0, 255)
    return out


def encode_fourdgs(path, capture: DynamicCapture, codec: str = "deflate", level: int | None = None,
                   profile: str = "default") -> bytes:
    """level None: deflate 1 (3x faster than fourdgs' 6 on 200k test splats, ~10% larger), zstd 3."""
    level = DEFAULT_LEVEL.get(codec, 1) if level is None else level
    if codec not in wire.CODEC_IDS or profile not in PROFILES:
        raise ValueError(f"codec {codec!r} / profile {profile!r}: codecs {list(wire.CODEC_IDS)}, "
                         f"profiles {list(PROFILES)}")
    c = _as_fourdgs(path, capture)
    n, duration = c.count, float(c.t_end)
    median = float(np.median(c.scales)) if n else 0.0
    bounds, steps = _steps(profile, median if 0 < median < np.inf else 1e-3)
    origin = c.positions.min(axis=0).astype(np.float64) if n else np.zeros(3)
    symbols, table = _quantise(path, c, steps, origin)
    sh = _sh_bytes(c)
    aabb = [*origin, *(c.positions.max(axis=0) if n else np.zeros(3))]
    header = (wire.put_string("") + wire.put_string("Splatline") + struct.pack("<dQd", duration, n, c.cutoff)
              + wire.put_string("gaussian-birth") + struct.pack("<6dBB", *aabb, c.sh_degree, 0) + wire.put_str_map({}))
    quant = (wire.put_string("uniform-v1") + struct.pack("<3d8dB", *origin, *(steps[k] for k in STEP_NAMES), 1)
             + wire.put_str_map({k: repr(float(v)) if k != "sh" else "0" for k, v in bounds.items()}))
    windows = struct.pack("<I", len(table)) + table.astype("<f8").tobytes()
    parts = [wire.MAGIC, wire.put_record(wire.HEADER, header), wire.put_record(wire.QUANTIZATION, quant),
             wire.put_record(wire.WINDOW_TABLE, windows)]
    at, index = sum(map(len, parts)), []
    for first in range(0, n, CHUNK_SPLATS):
        rows = slice(first, min(n, first + CHUNK_SPLATS))
        count = rows.stop - rows.start
        streams = b"".join(wire.put_stream(path, ident, values[rows], codec, level, f"attribute {ident}")
                           for ident, values in symbols.items())
        chunk = wire.put_record(wire.CHUNK, struct.pack("<ddII", 0.0, duration, 0, count) + wire.put_string("")
                                + struct.pack("<QQ", len(streams), len(streams)) + streams)
        entry = [struct.pack("<ddQQI", 0.0, duration, at, len(chunk), count)]
        parts.append(chunk)
        at += len(chunk)
        for band, values in sh.items():
            record = wire.put_record(wire.SH_BAND_STREAM, struct.pack("<B", band) + wire.put_stream(
                path, wire.SH_BAND_STREAM, values[rows], codec, level, f"SH band {band}"))
            entry.append(struct.pack("<BQQ", band, at, len(record)))
            parts.append(record)
            at += len(record)
        entry.insert(1, struct.pack("<I", len(entry) - 1))
        index.append(wire.put_record(wire.CHUNK_INDEX, b"".join(entry)))
    summary = b"".join(index)
    footer = struct.pack("<QQI", at if summary else 0, 0, zlib.crc32(summary) if summary else 0)
    return b"".join(parts) + summary + wire.put_record(wire.FOOTER, footer) + wire.MAGIC


def write_fourdgs(path, capture: DynamicCapture, codec: str = "deflate", level: int | None = None,
                  profile: str = "default") -> None:
    write_file(path, encode_fourdgs(path, capture, codec, level, profile))
