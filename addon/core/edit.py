"""Edits on a SplatSet for the command line (the splat-transform actions): a similarity
transform, filters (box, sphere, a value test on activated quantities), importance
decimation, merging, and per-column statistics. Pure numpy; every function returns a new set.
"""
from __future__ import annotations

import operator
import re

import numpy as np

from . import linear_map
from .reframe import reframe
from .select import limit_count
from .splats import SplatSet, sh_coeff_count

OPS = {"<=": operator.le, ">=": operator.ge, "<": operator.lt, ">": operator.gt}
_TEST = re.compile(r"^\s*([a-z_0-9]+)\s*(<=|>=|<|>)\s*([-+0-9.eE]+)\s*$")


def _euler_matrix(degrees) -> np.ndarray:
    """Rotation about x, then y, then z (Blender's XYZ Euler), in degrees."""
    x, y, z = np.radians(np.asarray(degrees, np.float64))
    rx = np.array([[1, 0, 0], [0, np.cos(x), -np.sin(x)], [0, np.sin(x), np.cos(x)]])
    ry = np.array([[np.cos(y), 0, np.sin(y)], [0, 1, 0], [-np.sin(y), 0, np.cos(y)]])
    rz = np.array([[np.cos(z), -np.sin(z), 0], [np.sin(z), np.cos(z), 0], [0, 0, 1]])
    return rz @ ry @ rx


def transform(splats: SplatSet, translate=(0, 0, 0), rotate=(0, 0, 0), scale=1.0) -> SplatSet:
    """p' = scale * R p + translate. Splats turn with R (quaternions and SH bands, so the
    view-dependent colour turns too) and grow with scale."""
    if scale <= 0 or not np.isfinite(scale):
        raise ValueError(f"scale must be a positive number, not {scale}")
    return linear_map.bake(splats, scale * _euler_matrix(rotate), translate)


def keep_box(splats: SplatSet, lo, hi) -> SplatSet:
    p = splats.positions
    return splats.subset(((p >= np.asarray(lo)) & (p <= np.asarray(hi))).all(axis=1))


def keep_sphere(splats: SplatSet, centre, radius: float) -> SplatSet:
    d = splats.positions.astype(np.float64) - np.asarray(centre, np.float64)
    return splats.subset(np.einsum("ij,ij->i", d, d) <= float(radius) ** 2)


def column(splats: SplatSet, name: str) -> np.ndarray:
    """An activated per-splat quantity by name: x y z, opacity (0..1), scale (the largest
    linear axis), scale_0..2, volume (product of scales), r g b (DC colour 0..1)."""
    from .sh import C0

    axes = {"x": 0, "y": 1, "z": 2}
    if name in axes:
        return splats.positions[:, axes[name]]
    if name == "opacity":
        return splats.opacities
    if name == "scale":
        return splats.scales.max(axis=1)
    if re.fullmatch(r"scale_[012]", name):
        return splats.scales[:, int(name[-1])]
    if name == "volume":
        return splats.scales.astype(np.float64).prod(axis=1)
    if name in ("r", "g", "b"):
        return 0.5 + C0 * splats.sh_dc[:, "rgb".index(name)]
    raise ValueError(f"unknown quantity {name!r}; known: {', '.join(COLUMNS)}")


COLUMNS = ("x", "y", "z", "opacity", "scale", "scale_0", "scale_1", "scale_2", "volume", "r", "g", "b")


def parse_test(text: str):
    """'opacity>0.1' -> (name, op, value); ValueError with the reason otherwise."""
    m = _TEST.match(text)
    if not m:
        raise ValueError(f"{text!r} is not NAME<VALUE, NAME<=VALUE, NAME>VALUE or NAME>=VALUE")
    name, op, value = m.groups()
    if name not in COLUMNS:
        raise ValueError(f"unknown quantity {name!r} in {text!r}; known: {', '.join(COLUMNS)}")
    return name, op, float(value)


def keep_where(splats: SplatSet, test: str) -> SplatSet:
    name, op, value = parse_test(test)
    return splats.subset(OPS[op](column(splats, name), value))


def parse_count(text: str, total: int) -> int:
    """'50000' or '25%' of total -> a splat count."""
    t = text.strip()
    try:
        n = round(total * float(t[:-1]) / 100) if t.endswith("%") else int(t)
    except ValueError:
        raise ValueError(f"{text!r} is not a count (N) or a percentage (N%)") from None
    if n < 0 or (t.endswith("%") and not 0 <= float(t[:-1]) <= 100):
        raise ValueError(f"{text!r} must be a count >= 0 or a percentage in 0..100")
    return min(n, total)


def decimate(splats: SplatSet, count: int) -> SplatSet:
    """The `count` most important splats (opacity x volume), in their original order."""
    return limit_count(splats, count)


def merge(sets: list) -> SplatSet:
    """One set of all splats, in the first set's axis convention and the highest SH degree
    among them (missing bands are zero: no view-dependent colour, as the source had);
    anti-aliased where every set is."""
    axes = sets[0].axes
    sets = [reframe(s, axes) for s in sets]
    k = max(sh_coeff_count(s.sh_degree) for s in sets)
    rest = [np.pad(s.sh_rest, ((0, 0), (0, k - s.sh_rest.shape[1]), (0, 0))) for s in sets]
    cat = {f: np.concatenate([getattr(s, f) for s in sets]) for f in
           ("positions", "scales", "rotations", "opacities", "sh_dc")}
    # anti-aliased only where every input was (splat-transform also drops a disagreeing tag)
    return SplatSet(**cat, sh_rest=np.concatenate(rest).astype(np.float32), axes=axes,
                    antialiased=all(s.antialiased for s in sets)).check()


def statistics(splats: SplatSet, replaced=None) -> dict:
    """{quantity: {min, max, mean, std, nonfinite}} over the activated quantities.
    replaced: (rows, originals) from check_values(keep_replaced=True): those rows are
    measured as they were in the file, so a value "fix" replaced counts as NaN/Inf in its
    own column and stays out of the figures."""
    out = {}
    for name in COLUMNS:
        v = np.array(column(splats, name), np.float64)
        if replaced is not None and len(replaced[0]):
            with np.errstate(invalid="ignore", over="ignore"):
                v[replaced[0]] = column(replaced[1], name)
        ok = v[np.isfinite(v)]
        stats = (ok.min(), ok.max(), ok.mean(), ok.std()) if ok.size else (np.nan,) * 4
        out[name] = dict(zip(("min", "max", "mean", "std"), map(float, stats)),
                         nonfinite=int(v.size - ok.size))
    return out
