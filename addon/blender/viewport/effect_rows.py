"""Effects the viewport applies in its preprocess pass: which ones it can, and the table
rows the shader reads the colour effects from (no bpy, no gpu). A morph has no row: the
object's row holds its amount, and the target's own textures hold the rest.

An effect reaches the pass through its kind's declaration (EffectKind.gpu: the program
applying it, and its params as that program's); everything here is keyed by the program
(a Deferred's `program`), never by the params' type.

Scrubbing a reveal or a grade on the CPU rewrites and re-uploads the opacity, scale and
colour of every splat each frame, and a displace its centres; here a frame uploads a few
texels of parameters instead, and shaders/viewport_effects.glsl applies the numpy kernels'
arithmetic (core/effects/reveal.py, grade.py, displace.py) to the base splats. Which
effects may leave the stack is core/effects/deferral.py's rule; final renders and
Blender's own engines never defer.

Rows, EFFECT_TEXELS texels of RGBA32F per effect, after the objects' rows in the same
table texture:
    0      kind (1 reveal, 2 grade), field (0 height, 1 distance, 2 noise), at rest, amount
    1..3   rows 0..2 of gizmo-local from object (field = these applied to the centre);
           noise: 1.x the texel of the fields texture holding the object's first splat's
           value (the core's memoized noise at the rest centres, field_values' mapping)
displace (kind 3; its noise layers are the displace_a and displace_b textures):
    1      weight of layer a, weight of layer b (0 where the kernel blends one), gain
reveal:
    4      progress, -1 / width, invert, amount * shrink
    5      glow colour rgb, 4 amount glow_strength / C0 (0: no glow)
    6      hard edge (width <= 0)
grade:
    4      low, 1 / (high - low) (1e12 when equal), mode (0 mix, 1 multiply, 2 add), stops
    5..7   stops by position: position, rgb
"""
from __future__ import annotations

import numpy as np

from ...core.effects import registry
from ...core.effects.common import F32, inverse, is_identity
from ...core.effects.grade import MODES
from ...core.sh import C0

EFFECT_TEXELS = 8
MAX_STOPS = 3
REVEAL, GRADE, DISPLACE = 1, 2, 3
_REVEAL_FIELDS = {"PLANE": 0, "SPHERE": 1, "NOISE": 2}
_GRADE_FIELDS = {"HEIGHT": 0, "DISTANCE": 1, "NOISE": 2}


def _finite(*values) -> bool:
    return bool(np.isfinite(np.asarray(values, np.float64)).all())


def on_gpu(params) -> bool:
    """Whether the preprocess pass can apply this effect: a kind declaring a GPU path
    (EffectKind.gpu) whose params, as its program's, are within that program's reach:
    reveal and grade (by height, distance or noise), displace, and a morph of any pairing
    (deferral.drawn_splats hands over its ends in order). Amount and shrink within [0, 1]
    (the panel's ranges) keep the base scales an upper bound of what a colour effect
    draws, which the sort's culling radius relies on."""
    path = registry.of(params).gpu
    if path is None:
        return False
    p = path.params_for(params)
    if not (getattr(p, "active", False) and 0.0 < p.amount <= 1.0):
        return False
    if not _finite(np.asarray(p.frame, np.float64)):
        return False
    return _TAKES[path.program](p)


def _takes_reveal(p) -> bool:
    return (p.shape in _REVEAL_FIELDS and 0.0 <= p.shrink <= 1.0
            and _finite(p.progress, p.width, p.glow_strength, *p.glow_color))


def _takes_grade(p) -> bool:
    return (p.field in _GRADE_FIELDS and p.mode in MODES and 1 <= len(p.stops) <= MAX_STOPS
            and _finite(p.low, p.high) and all(_finite(x, *rgb) for x, rgb in p.stops))


def _takes_displace(p) -> bool:  # at amplitude 0 the kernel returns its input: no layers
    return p.amplitude != 0.0 and _finite(p.amplitude, p.frequency, p.speed)


def _takes_morph(p) -> bool:  # any pairing: the renderer is handed its ends in order
    return p.amount < 1.0 and p.target is not None


# what each program takes, by its name (core.effects.kind.GPU_PROGRAMS)
_TAKES = {"reveal": _takes_reveal, "grade": _takes_grade, "displace": _takes_displace,
          "morph": _takes_morph}


def morph_of(deferred: tuple):
    """The deferred morph's params (the first deferred effect, split_stack's rule), or None."""
    return deferred[0].params if deferred and deferred[0].program == "morph" else None


def mover_of(deferred: tuple):
    """The deferred effect whose centres the preprocess pass moves (a displace or a morph:
    Deferred.centres set), or None."""
    return next((d for d in deferred if d.centres is not None), None)


def displace_of(deferred: tuple):
    """The deferred displace (a Deferred carrying its layers), or None."""
    return next((d for d in deferred if d.program == "displace"), None)


def displace_layers(d) -> tuple:
    """A deferred displace's (layer a, layer b) rows: b is a again where the kernel blends
    one layer (its weight is then 0)."""
    rows = [r for _, r in d.layers]
    return rows[0], rows[-1]


def is_noise(params) -> bool:
    return "NOISE" in (getattr(params, "shape", None), getattr(params, "field", None))


def effect_rows(deferred: tuple, field_starts: list = ()) -> np.ndarray:
    """(EFFECT_TEXELS rows per colour effect, 4) float32: the deferred colour effects'
    rows, in order (a morph's amount is on the object's row). field_starts: for each
    noise effect in order, the fields texture's texel of the object's first value."""
    deferred = [d for d in deferred if d.program != "morph"]
    rows = np.zeros((len(deferred) * EFFECT_TEXELS, 4), np.float32)
    starts = iter(field_starts)
    for k, d in enumerate(deferred):
        part = rows[k * EFFECT_TEXELS:(k + 1) * EFFECT_TEXELS]
        p = d.params
        if d.program == "displace":
            part[0, 0] = DISPLACE
            part[1, :3] = _displace_weights(d)
            continue
        if d.program not in _COLOUR_ROWS:
            raise ValueError(f"the viewport has no rows for the program {d.program!r}")
        if is_noise(p):
            part[1, 0] = next(starts)
        else:
            part[1:4] = (np.eye(4) if is_identity(p.frame) else inverse(p.frame))[:3]
        _COLOUR_ROWS[d.program](part, p, d.at_rest)
    return rows


def _displace_weights(d) -> tuple:
    """(weight a, weight b, gain) as the kernel rounds them (displace.apply)."""
    (w0, _), *second = d.layers
    w1 = second[0][0] if second else 0.0
    return F32(w0), F32(w1), F32(d.params.amount * d.params.amplitude)


def _reveal(part: np.ndarray, p, at_rest: bool) -> None:
    """Row 0 and the reveal program's rows, from a Reveal's params."""
    part[0] = (REVEAL, _REVEAL_FIELDS[p.shape], at_rest, p.amount)
    # each constant as the kernel rounds it: the float64 expression, then float32
    hard = p.width <= 0.0
    part[4] = (p.progress, 0.0 if hard else -1.0 / p.width, p.invert, p.amount * p.shrink)
    gain = 4.0 * p.amount * p.glow_strength / C0 if p.glow_strength > 0.0 else 0.0
    part[5] = (*p.glow_color[:3], gain)
    part[6, 0] = hard


def _grade(part: np.ndarray, p, at_rest: bool) -> None:
    """Row 0 and the grade program's rows, from a Grade's params."""
    part[0] = (GRADE, _GRADE_FIELDS[p.field], at_rest, p.amount / C0)
    scale = 1.0 / (p.high - p.low) if p.high != p.low else 1e12
    stops = sorted(p.stops, key=lambda s: s[0])  # stable, as grade.gradient's
    part[4] = (p.low, scale, MODES.index(p.mode), len(stops))
    for k, (x, rgb) in enumerate(stops):
        part[5 + k] = (x, *rgb[:3])


_COLOUR_ROWS = {"reveal": _reveal, "grade": _grade}  # the colour programs' rows, by name
