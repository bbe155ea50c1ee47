"""Colour grade by field: a gradient of two or more colour stops, indexed by height,
distance or noise, blended onto the DC colour (the view-independent part).

x = clip((f - low) / (high - low), 0, 1); g = piecewise-linear gradient of the stops at x;
with c = C0 * dc + 0.5 the base colour, MIX gives c + amount (g - c), MULTIPLY
c (1 + amount (g - 1)), ADD c + amount g. Only the DC changes: higher SH bands (the
view-dependent sheen) are kept, and positions are never touched.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..sh import C0
from .common import F32, EffectParams, for_blocks
from .field_memo import rows_field
from .kind import FREQUENCY, SEED, EffectKind, Field, GpuPath
from .noise import rest_field

FIELDS = ("HEIGHT", "DISTANCE", "NOISE")
MODES = ("MIX", "MULTIPLY", "ADD")


@dataclass
class Grade(EffectParams):
    field: str = "HEIGHT"
    stops: tuple = ((0.0, (0.1, 0.2, 1.0)), (1.0, (1.0, 0.4, 0.1)))
    low: float = 0.0
    high: float = 1.0
    mode: str = "MIX"
    frequency: float = 1.0
    seed: int = 0


def gradient(x: np.ndarray, stops) -> list[np.ndarray]:
    """Per-channel piecewise-linear colour at x (float32 columns, x in [0, 1]), constant
    beyond the end stops, as np.interp; stops are (position, rgb) in any order."""
    ordered = sorted(stops, key=lambda s: s[0])
    out = [None, None, None]   # None: still the first stop's colour
    for (x0, c0), (x1, c1) in zip(ordered, ordered[1:]):
        if x1 > x0:
            if x0 == 0.0 and x1 == 1.0:
                w = x  # (x - 0) * 1 clipped to [0, 1]: x itself, as x is already clipped
            else:
                w = x - F32(x0)
                w *= F32(1.0 / (x1 - x0))
                np.clip(w, 0.0, 1.0, out=w)
        else:  # two stops at one position: a hard step
            w = (x >= F32(x0)).astype(F32)
        for c in range(3):
            if c1[c] != c0[c]:
                step = w * F32(c1[c] - c0[c])
                if out[c] is None:  # the first stop's colour + step, added in either order
                    step += F32(ordered[0][1][c])
                    out[c] = step
                else:
                    out[c] += step
    return [np.full(x.shape[0], ordered[0][1][c], F32) if g is None else g
            for c, g in enumerate(out)]


def apply(splats, p: Grade, time: float = 0.0, rest=None):
    if not p.active or not p.stops or splats.count == 0:
        return splats
    if p.mode not in MODES:
        raise ValueError(f"Grade mode {p.mode!r} is not one of {MODES}")
    if p.field not in FIELDS:
        raise ValueError(f"Grade field {p.field!r} is not one of {FIELDS}")
    noise = rest_field(splats, rest, p) if p.field == "NOISE" else None
    field = rows_field(splats, rest, p.frame, p.field, noise)
    dc = np.empty_like(splats.sh_dc)

    def block(part):
        x = field(part)
        if not x.flags.writeable:  # the memoized field: grade_block works in place
            x = x.copy()
        grade_block(splats.sh_dc[part], x, p, dc[part])

    for_blocks(splats.count, block)
    return replace(splats, sh_dc=dc)


def grade_block(sh_dc: np.ndarray, x: np.ndarray, p: Grade, out: np.ndarray) -> None:
    x -= F32(p.low)
    x *= F32(1.0 / (p.high - p.low) if p.high != p.low else 1e12)
    np.clip(x, 0.0, 1.0, out=x)
    gain = F32(p.amount / C0)
    for c, g in enumerate(gradient(x, p.stops)):
        base = sh_dc[:, c]
        if p.mode == "ADD":
            delta = g
        else:
            colour = base * F32(C0)
            colour += F32(0.5)
            if p.mode == "MIX":
                g -= colour
                delta = g
            else:
                g -= F32(1.0)
                colour *= g
                delta = colour
        delta *= gain
        np.add(base, delta, out=out[:, c])


def _stops(values: dict) -> dict:
    stops = [(0.0, values["color_a"]), (1.0, values["color_b"])]
    if values["use_color_mid"]:
        stops.insert(1, (float(values["mid_position"]), values["color_mid"]))
    return {"stops": tuple(stops)}


def _colour(name, label, default):
    return Field(name, "COLOR", label, default, derived=True)


KIND = EffectKind(
    "GRADE", 4, "Colour Grade", "A colour gradient by height, distance or noise", "COLOR",
    Grade, apply, writes=frozenset({"sh_dc"}),
    gpu=GpuPath("grade"),
    moves_splats=False, depends_on_time=False, fields=(
        Field("grade_field", "ENUM", "Field", param="field", items=(
            ("HEIGHT", "Height", "Along the gizmo's Z"), ("DISTANCE", "Distance", "From the gizmo"),
            ("NOISE", "Noise", "Noise value 0..1"))),
        Field("grade_mode", "ENUM", "Blend Mode", param="mode", items=(
            ("MIX", "Mix", ""), ("MULTIPLY", "Multiply", ""), ("ADD", "Add", ""))),
        _colour("color_a", "Low Colour", (0.1, 0.2, 1.0)),
        _colour("color_b", "High Colour", (1.0, 0.4, 0.1)),
        Field("use_color_mid", "BOOL", "Middle Colour", False, derived=True),
        _colour("color_mid", "Middle Colour", (1.0, 1.0, 1.0)),
        Field("mid_position", "FLOAT", "Middle At", 0.5, derived=True,
              options={"min": 0.0, "max": 1.0, "subtype": "FACTOR"}),
        Field("range_low", "FLOAT", "Low", 0.0, "Field value of the low colour", param="low"),
        Field("range_high", "FLOAT", "High", 1.0, "Field value of the high colour", param="high"),
        FREQUENCY, SEED),
    derive=lambda values, fps: _stops(values))
