"""The effect stack: effects applied in order, each on the previous one's output.

Noise fields (Displace, Reveal and Grade by noise) are sampled at the splats' *rest*
positions while the splat count is unchanged: the pattern is attached to the splats (a
dissolve stays on flying fragments). The rest centres are the stack's input centres, or,
for splats that move by themselves (a dynamic capture), where each of them sits at rest,
which its source says. Since they are the same array every frame, the noise is evaluated
once and memoized (noise.field) however the splats move. After a morph that changes the
count, the current centres are used.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..splats import SplatSet
from . import registry


@dataclass
class StackResult:
    splats: SplatSet
    positions_changed: bool   # False: `splats.positions` is the input's own array


def apply_effect(splats: SplatSet, params, time: float, rest=None) -> SplatSet:
    return registry.of(params).kernel(splats, params, time, rest)


def evaluate_stack(splats: SplatSet, effects, time: float, rest=None) -> StackResult:
    """Apply `effects` (params objects, top of the stack first) at `time` seconds. rest:
    (count, 3) centres the noise fields sample, splat for splat; None: splats.positions.

    A pure function of its inputs: no state is carried from one call (frame) to the next.
    """
    out = splats
    rest = splats.positions if rest is None else rest
    for params in effects:
        out = apply_effect(out, params, time, rest if out.count == rest.shape[0] else None)
    return StackResult(out, out.positions is not splats.positions)
