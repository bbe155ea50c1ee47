"""Reading Avala AI's .4dgs (version 1, temporal model "gaussian-birth") into the 4dgs model.

Facts from the fourdgs 0.6.0 package (the format's reference implementation). The records
read (framing in fourdgs_wire.py; every other opcode is skipped by its length):
  Header (0x01)        profile, library, f64 duration_sec, u64 gaussian count, f64 cutoff,
                       temporal model, f64 aabb[6], u8 sh_degree, u8 flags, attributes map
  Quantization (0x03)  scheme "uniform-v1", f64 origin[3], f64 steps: pos, log scale, rotation,
                       rgb, alpha, motion, time, log sigma; u8 SH step, bounds map
  Window Table (0x04)  u32 n, n x (f64 lo, f64 hi)
  Chunk (0x05)         f64 t0, t1, u32 level, u32 count, compression ("", "deflate", "zstd"),
                       u64 uncompressed size, blob of attribute streams
  SH Band (0x07)       u8 band (1..3), one stream of 3 (2 band + 1) byte coefficients per
                       splat, red's then green's then blue's; belongs to the Chunk before it
  Chunk Index (0x08)   f64 t0, t1, u64 offset, u64 length, u32 count, bands (u8, u64, u64)
  Footer (0x02)        u64 summary start, u64 summary-offset start, u32 CRC-32 of the summary
                       (the bytes from summary start to the Footer)
Quantised values (bins b): position b step + origin; scale exp(b step); rotation the
smallest three of xyzw (the omitted largest, index in its own stream, is sqrt(1 - sum));
colour (g, r - g, b - g) bins x step clamped to [0, 1]; sigma exp(b step) or +inf where
flag bit 0 says "never fades"; velocity and mu_t on per-splat grids derived from the sigma
bin (life_class, mu_step below). Splats keep the file's order (chunk by chunk).
"""
from __future__ import annotations

import math
import zlib

import numpy as np

from .. import budget
from ..errors import SplatFormatError
from ..formats.readfile import read_whole
from ..formats._common import check_budget, file_size
from ..sh import C0
from ..splats import AXES_RDF
from . import fourdgs_wire as wire
from .capture import DynamicCapture
from .ply_read import drop_bad

# attribute ids and their channels (the version-1 registry)
POSITION, SCALE, ROTATION_INDEX, ROTATION, COLOR, OPACITY, MOTION, MU_T, SIGMA_T, FLAGS, WINDOW_INDEX = range(11)
GAUSSIAN_ID = 13
ATTRIBUTES = {POSITION: 3, SCALE: 3, ROTATION_INDEX: 1, ROTATION: 3, COLOR: 3, OPACITY: 1, MOTION: 3, MU_T: 1,
              SIGMA_T: 1, FLAGS: 1, WINDOW_INDEX: 1}
SH_QUANT_LO, SH_QUANT_HI = -4.0, 4.0        # a stored SH byte b is LO + b (HI - LO) / 255
SH_BANDS = {1: (0, 3), 2: (3, 8), 3: (8, 15)}  # band -> [first, last) coefficient
SH_COEFFICIENTS = (SH_QUANT_LO + np.arange(256) * ((SH_QUANT_HI - SH_QUANT_LO) / 255.0)).astype(np.float32)
LIFE_REF, LIFE_CLASSES, LIFE_HALF = 0.5, (-4, 2), (0.02, 2.0)
MU_REL, MU_MIN_CLASS = 0.05, -10
STEP_NAMES = ("pos", "scale_log", "rot", "rgb", "alpha", "motion", "time", "sigma_log")


def support_k(cutoff: float) -> float:
    """|t - mu| <= k sigma  <=>  marginal >= cutoff."""
    return math.sqrt(-2.0 * math.log(cutoff))


def life_class(sigma_bins, sigma_log_step, never_fades, window_len, k) -> np.ndarray:
    """The velocity grid's class: ceil(log2(half life / 0.5)), the half life being k sigma
    (the window length for a splat that never fades) clamped to [0.02, 2]."""
    sigma = np.exp(np.asarray(sigma_bins, np.float64) * sigma_log_step)
    with np.errstate(invalid="ignore"):
        half = np.where(never_fades, np.nan_to_num(window_len, nan=LIFE_HALF[1]), k * sigma)
        cls = np.ceil(np.log2(np.clip(half, *LIFE_HALF) / LIFE_REF))
    return np.clip(cls, *LIFE_CLASSES)


def motion_steps(classes, step_motion: float) -> np.ndarray:
    return step_motion * np.exp2(-classes)


def mu_steps(sigma_bins, sigma_log_step, never_fades, step_time: float) -> np.ndarray:
    """The time centre's grid: step_time halved until at most 5% of the splat's sigma."""
    sigma = np.exp(np.asarray(sigma_bins, np.float64) * sigma_log_step)
    target = np.where(never_fades, step_time, np.minimum(step_time, MU_REL * sigma))
    return step_time * np.exp2(np.clip(np.floor(np.log2(target / step_time)), MU_MIN_CLASS, 0))


def _header(path, content) -> dict:
    r = wire.Reader(path, content, what="Header")
    head = dict(profile=r.string(), library=r.string(), duration=r.f64(), count=r.u64(), cutoff=r.f64(),
                temporal_model=r.string())
    r.take(48)  # aabb
    head["sh_degree"] = r.u8()
    if head["temporal_model"] != "gaussian-birth":
        raise SplatFormatError(path, f"temporal model {head['temporal_model']!r} is not read by Splatline (it reads "
                                     f"'gaussian-birth'; 'keyframe-delta' files are refused)")
    if not 0.0 < head["cutoff"] <= 1.0:
        raise SplatFormatError(path, f"Header cutoff {head['cutoff']} is not a threshold in (0, 1]")
    if not (math.isfinite(head["duration"]) and head["duration"] >= 0):
        raise SplatFormatError(path, f"Header duration {head['duration']} is not a finite time >= 0")
    if head["sh_degree"] > 3:
        raise SplatFormatError(path, f"Header SH degree {head['sh_degree']}; version 1 defines 0 to 3")
    return head


def _quantization(path, content) -> dict:
    r = wire.Reader(path, content, what="Quantization record")
    scheme = r.string()
    if scheme != "uniform-v1":
        raise SplatFormatError(path, f"quantisation scheme {scheme!r} is not read (Splatline reads 'uniform-v1')")
    origin = r.unpack("3d")
    steps = dict(zip(STEP_NAMES, r.unpack("8d")))
    if not all(math.isfinite(v) for v in (*origin, *steps.values())):
        raise SplatFormatError(path, "the Quantization record holds a non-finite step or origin")
    return dict(steps, origin=np.array(origin))


def _window_table(path, content) -> np.ndarray:
    r = wire.Reader(path, content, what="Window Table")
    n = r.u32()
    table = np.frombuffer(r.take(16 * n), "<f8").reshape(n, 2).copy()
    if np.isnan(table).any():
        raise SplatFormatError(path, "the Window Table holds NaN")
    return table if n else np.zeros((1, 2))  # no windows: every splat in [0, 0), never visible


def _index_entry(path, content, offset) -> tuple:
    r = wire.Reader(path, content, what=f"Chunk Index record at byte {offset}")
    t0, t1, chunk_at, length, count, bands = r.unpack("ddQQII")
    r.take(17 * bands)
    return chunk_at, length, count


class _Walk:
    """The record walk: header, grids and windows, then each chunk decoded into `out` as it
    passes (the Window Table must precede the chunks, as fourdgs' streamed reader needs)."""

    def __init__(self, path, data):
        self.path, self.data = path, data
        self.head = self.quant = self.footer = self.out = None
        self.windows = np.zeros((1, 2))  # no table: every splat in [0, 0), never visible
        self.chunks = []    # (offset, record length, count, first row, {band})
        self.index = []     # (offset, length, count) per Chunk Index entry
        self.seen = 0

    def run(self, max_splats) -> None:
        for opcode, offset, content in wire.records(self.path, self.data):
            if self.footer is not None:
                raise SplatFormatError(self.path, f"a record (opcode 0x{opcode:02X}) follows the Footer at byte "
                                                  f"{self.footer[0]}")
            if self.head is None and opcode != wire.HEADER:
                raise SplatFormatError(self.path, f"the first record is opcode 0x{opcode:02X}, not the Header")
            if opcode == wire.HEADER:
                if self.head is not None:
                    raise SplatFormatError(self.path, f"a second Header at byte {offset}")
                self.head = _header(self.path, content)
                rest = SH_BANDS[self.head["sh_degree"]][1] if self.head["sh_degree"] else 0
                # a chunk's streams are held as int64 symbols while they decode: measured
                # 870 bytes a splat at peak for 1M splats of degree 3 against the 616 one
                # copy takes, so the estimate counts two (an upper bound, issue 41)
                check_budget(self.path, self.head["count"], 3 * rest, max_splats, copies=2)
                self.out = _allocate(self.head["count"], rest)
            elif opcode == wire.QUANTIZATION:
                self.quant = _quantization(self.path, content)
            elif opcode == wire.WINDOW_TABLE:
                if self.chunks:
                    raise SplatFormatError(self.path, f"the Window Table at byte {offset} follows a Chunk")
                self.windows = _window_table(self.path, content)
            elif opcode == wire.CHUNK:
                self._chunk(offset, content)
            elif opcode == wire.SH_BAND_STREAM:
                self._band(offset, content)
            elif opcode == wire.CHUNK_INDEX:
                self.index.append(_index_entry(self.path, content, offset))
            elif opcode == wire.FOOTER:
                r = wire.Reader(self.path, content, what="Footer")
                self.footer = (offset, *r.unpack("QQI"))
            elif opcode == wire.DELTA_CHUNK:
                raise SplatFormatError(self.path, f"a Delta Chunk (keyframe-delta model) at byte {offset} in a "
                                                  f"gaussian-birth file")
            elif opcode == wire.OBJECT_TRACK:
                raise SplatFormatError(self.path, "object tracks (rigid per-object motion, record 0x25) are not "
                                                  "read by Splatline")
        if self.footer is None:
            raise SplatFormatError(self.path, "truncated: no Footer record")

    def _chunk(self, offset, content) -> None:
        if self.quant is None:
            raise SplatFormatError(self.path, f"the Chunk at byte {offset} comes before the Quantization record")
        what = f"Chunk at byte {offset}"
        r = wire.Reader(self.path, content, what=what)
        r.unpack("dd")
        _level, count = r.unpack("II")
        compression, size = r.string(), r.u64()
        block = r.take(r.u64())
        first = self.seen
        self.seen += count
        if self.seen > self.head["count"]:
            raise SplatFormatError(self.path, f"the chunks hold more splats than the Header's {self.head['count']}")
        if compression:
            cap = (1 << 20) + 256 * count  # far above what 11 streams of 32-bit symbols take
            if size > cap:
                raise SplatFormatError(self.path, f"{what}: declares {size} bytes of streams for {count} splats")
            block = wire.decompress(self.path, block, compression, size, what)
        elif size != len(block):
            raise SplatFormatError(self.path, f"{what}: declares {size} bytes of streams, holds {len(block)}")
        streams, cur = {}, wire.Reader(self.path, block, what=what)
        while cur.remaining():
            ident, values = wire.read_stream(self.path, cur, ATTRIBUTES, count, what)
            if ident == GAUSSIAN_ID:
                raise SplatFormatError(self.path, f"{what}: a gaussian_id stream (keyframe-delta only)")
            if ident in streams:
                raise SplatFormatError(self.path, f"{what}: attribute {ident} appears twice")
            streams[ident] = values
        missing = sorted(set(ATTRIBUTES) - set(streams))
        if missing and count:
            raise SplatFormatError(self.path, f"{what}: attributes {missing} are missing")
        if count:
            rows = slice(first, self.seen)
            _decode_chunk(self.path, what, streams, self.quant, self.windows, support_k(self.head["cutoff"]),
                          {name: a[rows] for name, a in self.out.items()})
        self.chunks.append((offset, len(content) + 9, count, first, set()))

    def _band(self, offset, content) -> None:
        if not self.chunks:
            raise SplatFormatError(self.path, f"the SH band record at byte {offset} precedes every Chunk")
        what = f"SH band record at byte {offset}"
        r = wire.Reader(self.path, content, what=what)
        band, (_, _, count, row, bands) = r.u8(), self.chunks[-1]
        if not 1 <= band <= self.head["sh_degree"]:
            raise SplatFormatError(self.path, f"{what}: band {band} beyond the Header's SH degree "
                                              f"{self.head['sh_degree']}")
        first, last = SH_BANDS[band]
        ident, values = wire.read_stream(self.path, r, {wire.SH_BAND_STREAM: 3 * (last - first)}, count, what)
        if values is None or band in bands:
            raise SplatFormatError(self.path, f"{what}: not a band-{band} stream, or a second one for its chunk")
        if values.size and (values.min() < 0 or values.max() > 255):
            raise SplatFormatError(self.path, f"{what}: coefficients outside 0..255")
        bands.add(band)
        coeff = SH_COEFFICIENTS[values]  # a lookup, not float64 temporaries the size of the band
        self.out["sh_rest"][row:row + count, first:last] = coeff.reshape(count, 3, last - first).transpose(0, 2, 1)

    def check_summary(self) -> int:
        """Counts, the Footer's CRC of the index, the index against the chunks; returns the
        SH degree every chunk carries."""
        if self.quant is None:
            raise SplatFormatError(self.path, "no Quantization record")
        if self.seen != self.head["count"]:
            raise SplatFormatError(self.path, f"the Header declares {self.head['count']} splats, the chunks hold "
                                              f"{self.seen}")
        footer_at, start, _, crc = self.footer
        if start and not len(wire.MAGIC) <= start <= footer_at:
            raise SplatFormatError(self.path, f"the Footer's summary start {start} is outside the file's records")
        if start and crc and zlib.crc32(memoryview(self.data)[start:footer_at]) != crc:
            raise SplatFormatError(self.path, "the index fails its CRC-32 check (corrupt summary)")
        if self.index and sorted(self.index) != sorted(c[:3] for c in self.chunks):
            raise SplatFormatError(self.path, "the chunk index does not name the file's chunks")
        sets = {frozenset(c[4]) for c in self.chunks if c[2]}
        degree = max((max(s, default=0) for s in sets), default=0)
        if sets and sets != {frozenset(range(1, degree + 1))}:
            raise SplatFormatError(self.path, f"the chunks carry different SH bands ({sorted(map(sorted, sets))})")
        return degree


def _allocate(n: int, rest: int) -> dict:
    f32 = np.float32
    return dict(positions=np.empty((n, 3), f32), scales=np.empty((n, 3), f32), rotations=np.empty((n, 4), f32),
                opacities=np.empty(n, f32), sh_dc=np.empty((n, 3), f32), sh_rest=np.empty((n, rest, 3), f32),
                motion=np.empty((n, 1, 3), f32), t_center=np.empty(n, f32), t_scale=np.empty(n, f32),
                window=np.empty((n, 2), np.float64))


def read_fourdgs(path, max_splats=None) -> DynamicCapture:
    size = file_size(path)
    budget.check(path, size, "--max-memory", "the .4dgs file held in memory while it is decoded")
    data = read_whole(path, size)  # checked unchanged while it was read
    walk = _Walk(path, data)
    with np.errstate(over="ignore"):  # a float32 overflow becomes inf, and drop_bad counts it
        walk.run(max_splats)
    degree = walk.check_summary()
    out, head = walk.out, walk.head
    out["sh_rest"] = np.ascontiguousarray(out["sh_rest"][:, :SH_BANDS[degree][1] if degree else 0])
    capture = DynamicCapture(model="4dgs", omega=None, cutoff=float(head["cutoff"]), axes=AXES_RDF, t_start=0.0,
                             t_end=float(head["duration"]), unit="seconds", duration=float(head["duration"]),
                             source=".4dgs", **out)
    return drop_bad(capture.check())


def _decode_chunk(path, what, s, q, windows, k, out) -> None:
    """One chunk's symbols into `out`'s rows (float64 arithmetic, stored as float32)."""
    never = s[FLAGS][:, 0] & 1 != 0
    sigma_bins = s[SIGMA_T][:, 0]
    index = s[WINDOW_INDEX][:, 0]
    if index.min() < 0 or index.max() >= len(windows):
        raise SplatFormatError(path, f"{what}: names a window outside the {len(windows)}-entry Window Table")
    largest = s[ROTATION_INDEX][:, 0]
    if largest.min() < 0 or largest.max() > 3:
        raise SplatFormatError(path, f"{what}: a rotation index outside 0..3")
    out["window"][:] = windows[index]
    with np.errstate(invalid="ignore"):
        length = out["window"][:, 1] - out["window"][:, 0]
    out["positions"][:] = s[POSITION] * q["pos"] + q["origin"]
    out["scales"][:] = np.exp(s[SCALE] * q["scale_log"])
    out["t_scale"][:] = np.where(never, np.inf, np.exp(sigma_bins * q["sigma_log"]))
    out["rotations"][:] = _rotations(s[ROTATION_INDEX][:, 0], s[ROTATION], q["rot"])
    g = s[COLOR][:, 0]
    rgb = np.stack([s[COLOR][:, 1] + g, g, s[COLOR][:, 2] + g], axis=1) * q["rgb"]
    rgb = np.clip(rgb, 0.0, 1.0).astype(np.float32)  # fourdgs' colours are float32
    out["sh_dc"][:] = (rgb.astype(np.float64) - 0.5) / C0
    out["opacities"][:] = np.clip(s[OPACITY][:, 0] * q["alpha"], 0.0, 1.0)
    step = motion_steps(life_class(sigma_bins, q["sigma_log"], never, length, k), q["motion"])
    out["motion"][:, 0] = s[MOTION] * step[:, None]
    out["t_center"][:] = s[MU_T][:, 0] * mu_steps(sigma_bins, q["sigma_log"], never, q["time"])


def _rotations(largest, rest_bins, step) -> np.ndarray:
    """Smallest-three xyzw (the largest component left out, positive) as unit wxyz."""
    rest = np.clip(rest_bins * step, -1.0, 1.0)
    xyzw = np.zeros((len(largest), 4))
    others = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])[largest]
    np.put_along_axis(xyzw, others, rest, axis=1)
    xyzw[np.arange(len(largest)), largest] = np.sqrt(np.maximum(1.0 - (rest * rest).sum(axis=1), 0.0))
    xyzw /= np.linalg.norm(xyzw, axis=1, keepdims=True)
    return xyzw[:, [3, 0, 1, 2]]
