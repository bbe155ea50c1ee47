"""The effect stack: effects applied in order, each on the previous one's output."""
from __future__ import annotations

from dataclasses import dataclass

from ..splats import SplatSet
from . import displace, explode, grade, morph, reveal, twist

KERNELS = {
    reveal.Reveal: reveal.apply,
    displace.Displace: displace.apply,
    explode.Explode: explode.apply,
    twist.Twist: twist.apply,
    grade.Grade: grade.apply,
    morph.Morph: morph.apply,
}


@dataclass
class StackResult:
    splats: SplatSet
    positions_changed: bool   # False: `splats.positions` is the input's own array


def apply_effect(splats: SplatSet, params, time: float) -> SplatSet:
    try:
        kernel = KERNELS[type(params)]
    except KeyError:
        raise TypeError(f"no effect kernel for {type(params).__name__}") from None
    return kernel(splats, params, time)


def evaluate_stack(splats: SplatSet, effects, time: float) -> StackResult:
    """Apply `effects` (params objects, top of the stack first) at `time` seconds.

    A pure function of its inputs: no state is carried from one call (frame) to the next.
    """
    out = splats
    for params in effects:
        out = apply_effect(out, params, time)
    return StackResult(out, out.positions is not splats.positions)
