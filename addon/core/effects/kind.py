"""How an effect describes itself: one `EffectKind` per effect, declared beside its kernel.

Everything outside the kernel reads the description: the Blender property group and its
panel (fields), the operators' type menu, the evaluator (params built from the fields, a
cache key that holds the time only when `depends_on_time`, a positions key that changes
only when `moves_splats`, and the viewport's GPU path through `gpu`). registry.py holds
the table of kinds.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

from ..splats import ARRAYS

# Field types: FLOAT, INT, BOOL, ENUM (items: (id, label, description) rows), COLOR (RGB,
# read as a tuple), SPLATS (another splat object: the Blender layer hands its splats
# mapped into this object's space and paired with its splats, as (SplatSet, Pairing)).
FIELD_TYPES = ("FLOAT", "INT", "BOOL", "ENUM", "COLOR", "SPLATS")
ALL_FIELDS = frozenset(ARRAYS)


@dataclass(frozen=True)
class Field:
    """One setting of an effect: an animatable property of the Blender Effect item.

    `name` is the property's identifier, which saved files, keyframes and presets hold, so
    it never changes; kinds that share a setting (seed, frequency) share one Field.
    `options` are further property options (min, soft_max, subtype, unit)."""
    name: str
    type: str
    label: str
    default: Any = None
    description: str = ""
    param: str | None = None    # the params field it sets (None: the same name)
    derived: bool = False       # read only by the kind's `derive`, not passed as is
    items: tuple = ()
    options: dict = field(default_factory=dict, hash=False, compare=True)

    def __post_init__(self):
        if self.type not in FIELD_TYPES:
            raise ValueError(f"field {self.name!r}: type {self.type!r} is not one of {FIELD_TYPES}")


# The programs of the viewport's preprocess pass (shaders/viewport_effects.glsl), each of
# which applies one built-in kernel's arithmetic to that kernel's params:
#   "reveal", "grade": colour programs, writing opacities, scales and SH DC from a field
#     (height, distance or noise) measured at the drawn centres or the stack's input ones;
#   "displace": moves the stack's input centres by the blend of two noise layers;
#   "morph": blends the splats with a target's, paired in order.
GPU_PROGRAMS = ("reveal", "grade", "displace", "morph")
COLOUR_PROGRAMS = frozenset({"reveal", "grade"})
# what each program may write: a kind declaring it writes no more (EffectKind.writes)
PROGRAM_WRITES = {"reveal": frozenset({"opacities", "scales", "sh_dc"}), "grade": frozenset({"sh_dc"}),
                  "displace": frozenset({"positions"}), "morph": ALL_FIELDS}


@dataclass(frozen=True)
class GpuPath:
    """How the viewport's GPU path applies a kind: the preprocess program, and how the
    kind's params become that program's own params (the params of the built-in kind it
    was written for: a Reveal for "reveal"). None: the kind's params are those already.

    The promise a declaration makes: the program's kernel on `as_program(params)` gives
    the kind's kernel output, bit for bit (deferral.apply_deferred, which tests pin to
    evaluate_stack). Whether one set of params is within the program's reach (ranges,
    finiteness) is the viewport's to say (blender/viewport/effect_rows.on_gpu)."""
    program: str
    as_program: Callable | None = None  # params -> the program's params

    def __post_init__(self):
        if self.program not in GPU_PROGRAMS:
            raise ValueError(f"GPU program {self.program!r} is not one of {GPU_PROGRAMS}")

    def params_for(self, params):
        return params if self.as_program is None else self.as_program(params)


@dataclass(frozen=True)
class EffectKind:
    """An effect: its kernel, its parameters and what the evaluator must know about it.

    moves_splats: the kernel may change positions (the viewport re-packs and re-sorts).
    depends_on_time: its output changes with time itself, not only through keyframes
    (the cache key of an evaluated frame then holds the time).
    writes: the SplatSet fields its output may hold new values in (an upper bound); a kind
    writing only positions and rotations reads only those too (deferral.py relies on it).
    gpu: how the viewport's preprocess pass applies it itself (GpuPath), or None: the CPU
    evaluates it there too, and the renderer re-uploads what it writes each frame."""
    id: str                     # the Effect item's `type`, held by files and presets
    number: int                 # its enum value in saved files: unique, never reused
    label: str
    description: str
    icon: str                   # a Blender icon name
    params: type                # the kernel's EffectParams subclass
    kernel: Callable            # apply(splats, params, time, rest) -> SplatSet
    moves_splats: bool
    depends_on_time: bool
    fields: tuple = ()
    derive: Callable | None = None  # (field values by name, fps) -> further params
    opaque: tuple = ()          # params identified by their source's key, not by value
    writes: frozenset = ALL_FIELDS
    gpu: GpuPath | None = None

    def __post_init__(self):
        if self.gpu is not None and not self.writes <= PROGRAM_WRITES[self.gpu.program]:
            raise ValueError(f"effect {self.id}: the {self.gpu.program!r} program writes only "
                             f"{sorted(PROGRAM_WRITES[self.gpu.program])} (declare `writes`)")

    @property
    def target_field(self) -> str | None:
        """The name of the field that takes another splat object (a morph's target), or
        None: presets and the command line ask for a second object only then."""
        return next((f.name for f in self.fields if f.type == "SPLATS"), None)

    def make(self, values: dict, fps: float, **common):
        """The kernel's params from field values (by field name) and the common ones
        (enabled, amount, frame)."""
        params = dict(common)
        for f in self.fields:
            if not f.derived:
                params[f.param or f.name] = values[f.name]
        if self.derive is not None:
            params.update(self.derive(values, fps))
        return self.params(**params)


SEED = Field("seed", "INT", "Seed", 0, options={"min": 0})
FREQUENCY = Field("frequency", "FLOAT", "Frequency", 1.0, "Noise cells per gizmo unit",
                  options={"min": 0.0, "soft_max": 20.0})
