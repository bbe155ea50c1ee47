"""Generated dynamic captures for the tests and the bench: raw file values (what a trainer
writes), PLY files written straight from them (not through Splatline's writer), and the
Spacetime formulas evaluated in float64 from the raw values, independently of the capture."""
from __future__ import annotations

import math

import numpy as np

from addon.core.sh import C0

SPACETIME = (["x", "y", "z", "trbf_center", "trbf_scale", "nx", "ny", "nz"] + [f"motion_{i}" for i in range(9)]
             + ["f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2"]
             + [f"rot_{i}" for i in range(4)] + [f"omega_{i}" for i in range(4)])
LINEAR = (["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"] + [f"f_rest_{i}" for i in range(9)]
          + ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3",
             "trbf_center", "trbf_scale", "motion_0", "motion_1", "motion_2"])


def raw_spacetime(n: int, seed: int = 0, names=SPACETIME) -> np.ndarray:
    """n splats of raw (pre-activation) values, float32 structured, in `names` order."""
    rng = np.random.default_rng(seed)
    rec = np.zeros(n, [(name, "<f4") for name in names])
    for name in names:
        rec[name] = rng.normal(0.0, 0.3, n)
    rec["trbf_center"] = rng.uniform(0.0, 1.0, n)
    rec["trbf_scale"] = rng.uniform(-2.5, 0.5, n)  # widths 0.08 .. 1.6 of a segment
    rec["opacity"] = rng.normal(1.0, 2.0, n)
    for i in range(3):
        rec[f"scale_{i}"] = rng.uniform(-5.0, -2.0, n)
    rec["rot_0"] = rng.uniform(0.5, 1.0, n)
    for name in names:
        if name.startswith("f_dc_") and "f_rest_0" not in names:
            rec[name] = rng.uniform(0.0, 1.0, n)  # Spacetime: plain RGB
    return rec


def write_raw_ply(path, rec: np.ndarray, comments=()) -> None:
    lines = ["ply", "format binary_little_endian 1.0", *comments, f"element vertex {rec.shape[0]}"]
    lines += [f"property float {name}" for name in rec.dtype.names] + ["end_header", ""]
    with open(path, "wb") as f:
        f.write("\n".join(lines).encode("ascii"))
        f.write(rec.tobytes())


def _col(rec, names) -> np.ndarray:
    return np.stack([rec[n].astype(np.float64) for n in names], axis=1)


def raw_reference(rec: np.ndarray, t: float, rgb: bool = True) -> dict:
    """The Spacetime (or linear) formulas from raw file values, float64: every splat's centre,
    unit rotation (NaN where zero), opacity and SH DC at time t."""
    delta = t - rec["trbf_center"].astype(np.float64)
    names = rec.dtype.names
    cubic = "motion_8" in names
    m = _col(rec, [f"motion_{i}" for i in range(9 if cubic else 3)])
    centre = _col(rec, ["x", "y", "z"]) + m[:, 0:3] * delta[:, None]
    if cubic:
        centre += m[:, 3:6] * delta[:, None] ** 2 + m[:, 6:9] * delta[:, None] ** 3
    q = _col(rec, ["rot_0", "rot_1", "rot_2", "rot_3"])
    if "omega_0" in names:
        q = q + _col(rec, ["omega_0", "omega_1", "omega_2", "omega_3"]) * delta[:, None]
    norm = np.linalg.norm(q, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        q = q / norm[:, None]
        ratio = np.where(delta == 0, 0.0, delta / np.exp(rec["trbf_scale"].astype(np.float64)))
    opacity = 1.0 / (1.0 + np.exp(-rec["opacity"].astype(np.float64))) * np.exp(-ratio ** 2)
    dc = _col(rec, ["f_dc_0", "f_dc_1", "f_dc_2"])
    return {"centre": centre, "rotation": q, "opacity": opacity, "sh_dc": (dc - 0.5) / C0 if rgb else dc,
            "scale": np.exp(_col(rec, ["scale_0", "scale_1", "scale_2"]))}


def same_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per row, the largest component difference between quaternions up to sign."""
    return np.minimum(np.abs(a - b).max(axis=1), np.abs(a + b).max(axis=1))


def f32_tol(values: np.ndarray, ulps: float = 16.0) -> np.ndarray:
    """A float32 rounding tolerance for values of this size (a few ulps, relative)."""
    return ulps * np.finfo(np.float32).eps * np.maximum(np.abs(values), 1.0)


SEGMENT_TIMES = (0.0, 0.25, 0.5, 1.0, math.nextafter(1.0, 0.0))
