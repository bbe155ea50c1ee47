"""Reveal/Dissolve: a plane, sphere or noise threshold sweeps through the capture.

Field value f per splat (gizmo-local): PLANE = height along the gizmo's z, SPHERE = distance
from the gizmo's origin, NOISE = value noise mapped to [0, 1] at the splats' rest positions
(see stack.py: the pattern stays on the splats as other effects move them). Splats with f below
`progress` are shown; across a soft edge of `width` they fade (opacity) and shrink (scale,
by `shrink`), with an optional glow colour added at the edge. `invert` swaps the sides,
which turns a reveal into a dissolve.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..sh import C0
from .common import F32, EffectParams, add_rows, for_blocks, put_rows, scale_rows, smoothstep01
from .field_memo import rows_field
from .kind import FREQUENCY, SEED, EffectKind, Field, GpuPath
from .noise import rest_field

SHAPES = ("PLANE", "SPHERE", "NOISE")
_FIELD = {"PLANE": "HEIGHT", "SPHERE": "DISTANCE", "NOISE": "NOISE"}  # common.field_values


@dataclass
class Reveal(EffectParams):
    shape: str = "PLANE"
    progress: float = 0.0
    width: float = 0.1
    invert: bool = False
    shrink: float = 1.0
    glow_color: tuple = (1.0, 0.5, 0.1)
    glow_strength: float = 0.0
    frequency: float = 1.0
    seed: int = 0


def edge_position(f: np.ndarray, p: Reveal) -> np.ndarray:
    """s in [0, 1]: 1 well inside the shown side, 0 well outside, 0.5 at the threshold
    (a fresh array; f is only read)."""
    if p.width <= 0.0:
        return (f < F32(p.progress)).astype(F32)
    s = f - F32(p.progress)
    s *= F32(-1.0 / p.width)
    s += F32(0.5)
    return np.clip(s, 0.0, 1.0, out=s)


def glow_rows(sh_dc: np.ndarray, glow: np.ndarray, colour, out: np.ndarray) -> np.ndarray:
    """add_rows(sh_dc, colour, glow, out) where glow is +0 off the edge's band (s = 0 or 1):
    those rows get sh_dc + (+0 * colour), which is sh_dc + 0 (one flat add) when each
    channel's +0 * colour is +0, sh_dc itself when each is -0; only the band's rows are
    weighted. Bit for bit add_rows' result; mixed signs or a colour that is not finite
    take add_rows."""
    zeros = [F32(0.0) * F32(c) for c in colour[:3]]
    signs = {bool(np.signbit(z)) for z in zeros}
    if len(signs) > 1 or not all(np.isfinite(zeros)):
        return add_rows(sh_dc, colour, glow, out=out)
    if signs == {True}:
        np.copyto(out, sh_dc)
    else:
        np.add(sh_dc, F32(0.0), out=out)
    band = np.flatnonzero(glow != F32(0.0))  # nonzero on floats is ~10x slower than on bools
    if band.size:
        rows = np.take(sh_dc, band, axis=0)
        weight = glow[band]
        for c in range(3):
            rows[:, c] += weight * F32(colour[c])
        put_rows(out, band, rows)
    return out


def apply(splats, p: Reveal, time: float = 0.0, rest=None):
    if not p.active or splats.count == 0:
        return splats
    if p.shape not in _FIELD:
        raise ValueError(f"Reveal shape {p.shape!r} is not one of {SHAPES}")
    noise = rest_field(splats, rest, p) if p.shape == "NOISE" else None
    field = rows_field(splats, rest, p.frame, _FIELD[p.shape], noise)
    opacities = np.empty_like(splats.opacities)
    scales = np.empty_like(splats.scales) if p.shrink > 0.0 else None
    sh_dc = np.empty_like(splats.sh_dc) if p.glow_strength > 0.0 else None

    def block(part):
        s = edge_position(field(part), p)
        if sh_dc is not None:
            glow = s * (F32(1.0) - s)
            glow *= F32(4.0 * p.amount * p.glow_strength / C0)
            glow_rows(splats.sh_dc[part], glow, p.glow_color, sh_dc[part])
        hidden = smoothstep01(s)  # visibility, in place
        if not p.invert:
            hidden -= F32(1.0)
            hidden *= F32(-1.0)
        # hidden = 1 - visibility; opacity factor = 1 - amount * hidden
        fade = hidden * F32(-p.amount)
        fade += F32(1.0)
        np.multiply(splats.opacities[part], fade, out=opacities[part])
        if scales is not None:
            hidden *= F32(-p.amount * p.shrink)
            hidden += F32(1.0)
            scale_rows(splats.scales[part], hidden, out=scales[part])

    for_blocks(splats.count, block)
    changes = {"opacities": opacities}
    if scales is not None:
        changes["scales"] = scales
    if sh_dc is not None:
        changes["sh_dc"] = sh_dc
    return replace(splats, **changes)


KIND = EffectKind(
    "REVEAL", 0, "Reveal/Dissolve", "A plane, sphere or noise threshold sweeps the splats in or out",
    "MOD_BUILD", Reveal, apply, writes=frozenset({"opacities", "scales", "sh_dc"}),
    gpu=GpuPath("reveal"),
    moves_splats=False, depends_on_time=False, fields=(
        Field("reveal_shape", "ENUM", "Shape", param="shape", items=(
            ("PLANE", "Plane", "Height along the gizmo's Z"),
            ("SPHERE", "Sphere", "Distance from the gizmo"), ("NOISE", "Noise", "Noise value 0..1"))),
        Field("progress", "FLOAT", "Progress", 0.0,
              "Threshold: splats with a field value below it are shown",
              options={"soft_min": -5.0, "soft_max": 5.0}),
        Field("edge_width", "FLOAT", "Edge Width", 0.1, param="width",
              options={"min": 0.0, "soft_max": 2.0}),
        Field("invert", "BOOL", "Invert (Dissolve)", False),
        Field("shrink", "FLOAT", "Shrink", 1.0, options={"min": 0.0, "max": 1.0, "subtype": "FACTOR"}),
        Field("glow_color", "COLOR", "Glow Colour", (1.0, 0.45, 0.1)),
        Field("glow_strength", "FLOAT", "Glow", 0.0, options={"min": 0.0, "soft_max": 4.0}),
        FREQUENCY, SEED))
