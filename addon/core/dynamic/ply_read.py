"""Dynamic PLY: Spacetime Gaussians "lite" and linear-motion (FreeTimeGS-style) captures.

Spacetime lite (oppo-us-research/SpacetimeGaussians, ourslite.py): float32 vertex properties
x y z trbf_center trbf_scale nx ny nz motion_0..8 f_dc_0..2 opacity scale_0..2 rot_0..3
omega_0..3. f_dc is plain RGB (read as SH DC (rgb - 0.5) / C0), trbf_scale a log width,
t in [0, 1] within a 50-frame segment. The "full" model (f_dc_0..8 features and f_t_*,
decoded per pixel by a network) is refused.
Linear: INRIA properties (SH DC, f_rest) plus trbf_center, trbf_scale, motion_0..2, and
perhaps `comment cfg_args: start=S duration=D fps=F` (times then in seconds).

Bodies are read into memory this module owns (formats/readfile.py), never memory-mapped: a
file that shrinks, grows or is replaced while it is read gives one error line, not SIGBUS. Bad values (docs/dynamic.md):
a splat with NaN anywhere, or an infinite value outside opacity and trbf_scale, or a zero
rotation with no omega, is dropped and counted in capture.dropped by field.
"""
from __future__ import annotations

import re

import numpy as np

from ..errors import SplatFormatError
from ..formats._common import check_budget, sigmoid_
from ..formats.ply import columns, rest_names, sh_rest_from
from ..formats.plyheader import parse_header, read_body
from ..formats.readfile import OpenedFile
from ..sh import C0
from ..splats import AXES_RDF, FILE_MAX_DEGREE, RENDER_MAX_DEGREE, file_sh_degree, sh_coeff_count
from ..validate import TINY_SCALE
from .capture import DynamicCapture

POS, SCALE, ROT = ("x", "y", "z"), ("scale_0", "scale_1", "scale_2"), ("rot_0", "rot_1", "rot_2", "rot_3")
DC = ("f_dc_0", "f_dc_1", "f_dc_2")
TIME = ("trbf_center", "trbf_scale")
MOTION = tuple(f"motion_{i}" for i in range(9))
OMEGA = tuple(f"omega_{i}" for i in range(4))
REQUIRED = POS + TIME + MOTION[:3] + DC + ("opacity",) + SCALE + ROT
EXTRA_FLOATS = 24  # time, motion and omega floats a splat holds beyond a static one (budget)
_CFG = re.compile(r"^cfg_args:(.*)$", re.IGNORECASE)  # a header comment's text
_NUMBER = r"[=\s]+([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"


def vertex_names(path) -> list:
    """The vertex properties of a PLY (parse_header's checks apply)."""
    with OpenedFile(path) as f:
        vertex = parse_header(f).element("vertex")
    return vertex.names() if vertex is not None else []


def is_dynamic_names(names) -> bool:
    return "trbf_center" in names


def cfg_args(comments) -> dict:
    """start / duration / fps / sh_degree from a `comment cfg_args:` header line ({} if none)."""
    match = next(filter(None, (_CFG.match(text) for text in comments)), None)
    if match is None:
        return {}
    found = {}
    for key in ("start", "duration", "fps", "sh_degree"):
        value = re.search(key + _NUMBER, match.group(1), re.IGNORECASE)
        if value is not None:
            found[key] = float(value.group(1))
    return found


def _model(path, names: set) -> tuple[str, int]:
    if "f_t_0" in names or "f_dc_3" in names:
        raise SplatFormatError(path, "a Spacetime Gaussians 'full' capture (features f_dc_0..8 and f_t_*, "
                                     "decoded per pixel by its network) is not supported; export the 'lite' model")
    missing = [p for p in REQUIRED if p not in names]
    if missing:
        raise SplatFormatError(path, f"dynamic PLY vertex lacks {', '.join(missing)}")
    cubic = [p for p in MOTION[3:] + OMEGA if p in names]
    if cubic and len(cubic) != 10:
        lacking = [p for p in MOTION[3:] + OMEGA if p not in names]
        raise SplatFormatError(path, f"dynamic PLY has some of motion_3..8 / omega_0..3 but lacks {', '.join(lacking)}")
    rest = sum(1 for p in names if p.startswith("f_rest_"))
    if cubic and rest:
        raise SplatFormatError(path, "a Spacetime (motion_0..8, omega) PLY with f_rest is not a known layout")
    try:
        degree = file_sh_degree(rest // 3) if rest % 3 == 0 else -1
    except ValueError:
        degree = -1
    if degree < 0 or any(p not in names for p in rest_names(rest)):
        raise SplatFormatError(path, f"{rest} f_rest properties match no SH degree 0..{FILE_MAX_DEGREE}")
    return ("spacetime" if cubic else "linear"), degree


def read_dynamic_ply(path, max_splats=None) -> DynamicCapture:
    with OpenedFile(path) as f:
        header = parse_header(f)
        vertex = header.element("vertex")
        if vertex is None:
            raise SplatFormatError(path, "PLY has no vertex element")
        model, degree = _model(path, set(vertex.names()))
        check_budget(path, vertex.count, 3 * sh_coeff_count(degree) + EXTRA_FLOATS, max_splats)
        rec = read_body(f, header)["vertex"]  # checked unchanged since it was opened
    capture = decode(path, rec, model, degree)
    cfg = cfg_args(header.comments)
    if "duration" in cfg:
        start = cfg.get("start", 0.0)
        capture.unit, capture.start, capture.duration = "seconds", start, cfg["duration"]
        capture.t_start, capture.t_end, capture.fps = start, start + cfg["duration"], cfg.get("fps")
    return capture


def decode(path, rec: np.ndarray, model: str, degree: int) -> DynamicCapture:
    n, f32, f64 = rec.shape[0], np.float32, np.float64
    depth = 3 if model == "spacetime" else 1
    with np.errstate(over="ignore", invalid="ignore"):
        t_scale = np.exp(columns(rec, ("trbf_scale",), f64)[:, 0]).astype(f32)
        scales = np.exp(columns(rec, SCALE, f64)).astype(f32)
        opacities = sigmoid_(columns(rec, ("opacity",), f64)[:, 0]).astype(f32)
    dc = columns(rec, DC)
    if model == "spacetime":  # plain RGB -> the SH DC that renders as that RGB
        dc = ((dc.astype(f64) - 0.5) / C0).astype(f32)
    keep = sh_coeff_count(min(degree, RENDER_MAX_DEGREE))
    capture = DynamicCapture(
        model=model, positions=columns(rec, POS),
        motion=columns(rec, MOTION[:3 * depth]).reshape(n, depth, 3),
        rotations=columns(rec, ROT), omega=columns(rec, OMEGA) if model == "spacetime" else None,
        scales=scales, opacities=opacities, sh_dc=dc,
        sh_rest=np.ascontiguousarray(sh_rest_from(rec, sh_coeff_count(degree), keep)),
        t_center=columns(rec, ("trbf_center",))[:, 0], t_scale=t_scale, axes=AXES_RDF,
        source="spacetime-lite PLY" if model == "spacetime" else "linear-motion PLY")
    return drop_bad(capture)


def drop_bad(capture: DynamicCapture) -> DynamicCapture:
    """Drop splats with NaN anywhere or infinities outside opacity and t_scale, and those whose
    rotation is zero at every time; count them by field in capture.dropped. Zero scales (an
    underflowed exp) become TINY_SCALE, as core/validate.py's 'fix' does."""
    n = capture.count
    if n == 0:  # nothing to check (and reshape(0, -1) has no width to infer)
        return capture
    checks = {
        "position": capture.positions, "motion": capture.motion.reshape(n, -1),
        "rotation": capture.rotations, "scale": capture.scales, "colour": capture.sh_dc,
        "sh_rest": capture.sh_rest.reshape(n, -1), "trbf_center": capture.t_center[:, None],
    }
    if capture.omega is not None:
        checks["omega"] = capture.omega
    bad = np.zeros(n, bool)
    for name, arr in checks.items():
        hit = ~np.isfinite(arr).all(axis=1) if arr.shape[1] else np.zeros(n, bool)
        _count(capture, name, hit & ~bad)
        bad |= hit
    for name, arr in (("opacity", capture.opacities), ("trbf_scale", capture.t_scale)):
        hit = np.isnan(arr)
        _count(capture, name, hit & ~bad)
        bad |= hit
    still = ~capture.rotations.any(axis=1)
    if capture.omega is not None:
        still &= ~capture.omega.any(axis=1)
    _count(capture, "zero_rotation", still & ~bad)
    bad |= still
    np.maximum(capture.scales, np.float32(TINY_SCALE), out=capture.scales)
    return subset(capture, ~bad) if bad.any() else capture


def _count(capture: DynamicCapture, name: str, hit: np.ndarray) -> None:
    k = int(np.count_nonzero(hit))
    if k:
        capture.dropped[name] = capture.dropped.get(name, 0) + k


def subset(capture: DynamicCapture, mask: np.ndarray) -> DynamicCapture:
    """The capture's splats picked by a boolean mask (one segment only)."""
    pick = {name: (None if getattr(capture, name) is None else np.ascontiguousarray(getattr(capture, name)[mask]))
            for name in ("positions", "motion", "rotations", "omega", "scales", "opacities", "sh_dc",
                         "sh_rest", "t_center", "t_scale", "window")}
    fields = {k: getattr(capture, k) for k in ("model", "cutoff", "axes", "t_start", "t_end", "unit", "fps",
                                               "duration", "start", "dropped", "source")}
    return DynamicCapture(**pick, **fields)
