"""Write dynamic PLYs: Spacetime lite (the property order its code writes) and linear-motion
(INRIA order plus trbf_center, trbf_scale, motion_0..2, and a cfg_args comment in seconds)."""
from __future__ import annotations

import numpy as np

from ..errors import SplatFormatError
from ..formats._common import logit, write_file, write_files
from ..formats.ply import rest_names
from ..sh import C0
from ..splats import sh_coeff_count
from .capture import DynamicCapture
from .ply_read import DC, MOTION, OMEGA, POS, ROT, SCALE

SPACETIME_ORDER = (POS + ("trbf_center", "trbf_scale", "nx", "ny", "nz") + MOTION + DC + ("opacity",)
                   + SCALE + ROT + OMEGA)


def _log(x: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore"):
        return np.log(x.astype(np.float64))


def _values(capture: DynamicCapture, rows: slice, rgb: bool) -> dict:
    """Property name -> (n,) or (n, k) values of the splats in rows."""
    values = {
        POS: capture.positions[rows], ("trbf_center",): capture.t_center[rows],
        ("trbf_scale",): _log(capture.t_scale[rows]), ("opacity",): logit(capture.opacities[rows]),
        SCALE: _log(capture.scales[rows]), ROT: capture.rotations[rows],
    }
    motion = capture.motion[rows]
    values[MOTION[:3 * motion.shape[1]]] = motion.reshape(motion.shape[0], -1)
    dc = capture.sh_dc[rows]
    values[DC] = C0 * dc.astype(np.float64) + 0.5 if rgb else dc
    if capture.omega is not None:
        values[OMEGA] = capture.omega[rows]
    return values


def _fill(rec: np.ndarray, values: dict) -> None:
    for names, arr in values.items():
        arr = arr.reshape(arr.shape[0], -1)
        for i, name in enumerate(names):
            rec[name] = arr[:, i]


def _header(names, count: int, comments=()) -> bytes:
    lines = ["ply", "format binary_little_endian 1.0", "comment written by Splatline", *comments,
             f"element vertex {count}"]
    lines += [f"property float {name}" for name in names] + ["end_header", ""]
    return "\n".join(lines).encode("ascii")


def encode_spacetime(path, capture: DynamicCapture, rows: slice = slice(None)) -> bytes:
    if capture.sh_degree:
        raise SplatFormatError(path, f"a Spacetime lite PLY holds no higher SH; the capture has degree "
                                     f"{capture.sh_degree} (write it as a linear-motion PLY)")
    rec = np.zeros(len(range(*rows.indices(capture.count))), [(n, "<f4") for n in SPACETIME_ORDER])
    _fill(rec, _values(capture, rows, rgb=True))
    return _header(SPACETIME_ORDER, rec.shape[0]) + rec.tobytes()


def encode_linear(path, capture: DynamicCapture) -> bytes:
    k = sh_coeff_count(capture.sh_degree)
    names = (POS + ("nx", "ny", "nz") + DC + tuple(rest_names(3 * k)) + ("opacity",) + SCALE + ROT
             + ("trbf_center", "trbf_scale") + MOTION[:3])
    rec = np.zeros(capture.count, [(n, "<f4") for n in names])
    values = _values(capture, slice(None), rgb=False)
    if k:  # channel-major in the file
        values[tuple(rest_names(3 * k))] = capture.sh_rest.transpose(0, 2, 1).reshape(capture.count, 3 * k)
    _fill(rec, values)
    comments = []
    if capture.unit == "seconds":
        fields = [f"start={capture.t_start!r}", f"duration={capture.t_end - capture.t_start!r}"]
        fields += [f"fps={capture.fps!r}"] if capture.fps else []
        comments = ["comment cfg_args: " + " ".join(fields + [f"sh_degree={capture.sh_degree}"])]
    return _header(names, capture.count, comments) + rec.tobytes()


def write_dynamic_ply(paths, capture: DynamicCapture) -> None:
    """One path per segment (a list for a multi-segment capture). Spacetime captures are
    written as Spacetime lite, linear ones as linear-motion PLYs."""
    paths = list(paths)
    if len(paths) != capture.segments:
        raise SplatFormatError(paths[0], f"the capture has {capture.segments} segments; give as many paths, "
                                         f"got {len(paths)}")
    if capture.model == "4dgs":
        raise SplatFormatError(paths[0], "a .4dgs capture's windows and 0.05 cut-off have no PLY form; "
                                         "convert it first (core.dynamic.convert)")
    if capture.model == "linear":
        if capture.segments != 1:
            raise SplatFormatError(paths[0], "a linear-motion PLY holds one segment")
        write_file(paths[0], encode_linear(paths[0], capture))
        return
    parts = []
    for k, path in enumerate(paths):
        a, b = int(capture.segment_offsets[k]), int(capture.segment_offsets[k + 1])
        parts.append((path, [encode_spacetime(path, capture, slice(a, b))]))
    write_files(parts)
