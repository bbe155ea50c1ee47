"""Which effects of a stack a renderer may apply itself, after the CPU's part.

The viewport can apply colour effects (those changing only opacities, scales and SH DC),
a displace and a morph in its preprocess pass, so that scrubbing them re-uploads nothing
per splat. A kind says which of the pass's programs applies it (EffectKind.gpu, a
kind.GpuPath): this module reads that declaration, never the params' type, and hands
the renderer each deferred effect as its program and that program's params.
Moving a colour effect out of the stack to its end is exact when nothing after it reads
what it writes and its field is measured at the same centres:
- an effect after it writes positions and rotations only (such kinds read only those,
  kind.EffectKind.writes), or is itself deferred, in order;
- its field's centres are the stack's input (no mover before it, `at_rest`) or the final
  ones (no mover after it). Whether a field kind can be deferred is `on_gpu`'s to say.
A morph is deferred when everything after it is: the renderer blends its two ends in order
(morph.aligned). A morph between sets of other sizes is deferred only where its ends are
gathered once while scrubbing (`_ends_kept`).
A displace is deferred when everything after it is and nothing before it moves the splats:
its input centres are then the stack's input, the same array every frame, and the renderer
adds the noise layers' blend to them itself. For either, the CPU still moves the centres as
the kernel does, since the renderer sorts by them (`drawn_splats`), but the renderer's copy
of the centres they start from stays as it was.

`split_stack` decides; `apply_deferred` is the readable CPU meaning of the result, which
tests pin to evaluate_stack bit for bit.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from ..splats import SplatSet
from . import registry
from .displace import noise_layers
from .kind import COLOUR_PROGRAMS
from .morph import aligned, morph_positions, pairing_for
from .stack import apply_effect

GEOMETRY = frozenset({"positions", "rotations"})
COLOUR = frozenset({"opacities", "scales", "sh_dc"})


@dataclass(frozen=True)
class Deferred:
    params: object      # its program's params (GpuPath.params_for: a Reveal, a Grade, a
                        # Displace or a Morph), which the program's kernel applies
    at_rest: bool       # its field is measured at the stack's input centres, not the final ones
    # as drawn_splats hands a displace or a morph over: the centres the renderer moves
    # itself (the handed splats hold the moved ones, to sort by): a displace's input, the
    # morph's source end
    centres: np.ndarray | None = field(default=None, compare=False)
    # and a displace's noise layers at the frame's time, ((weight, (N, 3) rows), ...) as
    # displace.noise_layers gives them
    layers: tuple = field(default=(), compare=False)
    # the preprocess program applying it (kind.GPU_PROGRAMS); left out, the one declared
    # by the kind whose params `params` are
    program: str = ""

    def __post_init__(self):
        if not self.program:
            object.__setattr__(self, "program", registry.of(self.params).gpu.program)


def split_stack(effects: list, on_gpu: Callable[[object], bool]) -> tuple[list, tuple]:
    """(the effects to evaluate on the CPU, in order; the Deferred ones, in order).
    Only kinds declaring a GPU path (EffectKind.gpu) are deferred, by its program's rule;
    on_gpu(params): whether the renderer can apply this effect itself."""
    kinds = [registry.of(p) for p in effects]
    movers = [kind.moves_splats for kind in kinds]
    deferred, kept_after = [], []
    cut = len(effects)
    for i in range(len(effects) - 1, -1, -1):
        p, kind = effects[i], kinds[i]
        path = kind.gpu
        program = path.program if path is not None else None
        if program == "morph":
            # its output is read by deferred effects only
            if not kept_after and on_gpu(p):
                q = path.params_for(p)
                if _ends_kept(q, effects[:i]):
                    deferred.append(Deferred(q, at_rest=False, program=program))
                    cut = i
            break  # what comes before it is the morph's source
        if program == "displace" and not kept_after and not any(movers[:i]) and on_gpu(p):
            deferred.append(Deferred(path.params_for(p), at_rest=True, program=program))
        elif kind.writes <= GEOMETRY:
            kept_after.append(p)
        elif (program in COLOUR_PROGRAMS and kind.writes <= COLOUR and on_gpu(p)
              and not (any(movers[:i]) and any(movers[i + 1:]))):
            deferred.append(Deferred(path.params_for(p), at_rest=not any(movers[:i]), program=program))
        else:
            break
        cut = i
    return list(effects[:cut]) + kept_after[::-1], tuple(deferred[::-1])


def _ends_kept(p, before: list) -> bool:
    """Whether a deferred morph's ends (morph.aligned) stay the same arrays from frame to
    frame. Without a pairing of its own the morph pairs its splats anew each frame
    (morph.pairing_for), and so gathers its ends anew. Paired in order, they are its
    source and target themselves; otherwise they are gathered from its source, whose
    arrays are the same each frame only when no active effect comes before it. Gathered
    anew each frame, they cost more than the blend on the CPU (a reveal, then a morph of
    1M splats to 750k: 1146 against 908 ms a frame)."""
    return p.pairing is not None and (p.pairing.in_order or not any(q.active for q in before))


def drawn_splats(splats: SplatSet, deferred: tuple, time: float = 0.0) -> tuple[SplatSet, tuple]:
    """What the renderer is handed: the CPU part's splats and the deferred effects. With a
    deferred morph (the first deferred effect) both become its ends (morph.aligned), paired
    in order: the source end with the centres blended as the kernel blends them (the
    renderer sorts by them), and the morph's target the target end. A deferred displace
    moves the handed centres as the kernel does (the renderer sorts by them too) and
    carries its noise layers at `time`. Either carries the centres it moves (Deferred.
    centres), which the renderer keeps while scrubbing. Otherwise the CPU part's splats
    and the deferred effects as they are."""
    if not deferred:
        return splats, deferred
    displace = next((k for k, d in enumerate(deferred) if d.program == "displace"), None)
    if displace is not None:
        p = deferred[displace].params
        layered = replace(deferred[displace], centres=splats.positions,
                          layers=tuple(noise_layers(splats.positions, p, time)))
        moved = apply_effect(splats, p, time, splats.positions)
        return moved, deferred[:displace] + (layered,) + deferred[displace + 1:]
    if deferred[0].program != "morph":
        return splats, deferred
    p = deferred[0].params
    ends = aligned(splats, p.target, pairing_for(splats, p))
    drawn = replace(ends.source, positions=morph_positions(ends.source.positions,
                                                           ends.target.positions, p.amount))
    morph = replace(deferred[0], params=replace(p, target=ends.target, pairing=ends.pairing),
                    centres=ends.source.positions)
    return drawn, (morph,) + deferred[1:]


def apply_deferred(splats: SplatSet, rest, deferred: tuple, time: float) -> SplatSet:
    """The deferred effects on the CPU's result: what a renderer applying them must draw
    (each program's kernel on its params). rest: the stack's input centres."""
    rest_or_none = rest if rest.shape[0] == splats.count else None  # as evaluate_stack
    for d in deferred:
        if d.program not in COLOUR_PROGRAMS:  # a morph or a displace moves the splats itself
            splats = apply_effect(splats, d.params, time, rest_or_none)
            continue
        field_at = rest if d.at_rest else splats.positions
        out = apply_effect(replace(splats, positions=field_at), d.params, time, rest_or_none)
        splats = replace(out, positions=splats.positions)
    return splats
