"""Per-splat effects: vectorised numpy kernels, the single source of truth for every renderer.

Each kernel is `apply(splats, params, time) -> SplatSet`: it never writes to its input and
returns a set that shares every array it did not change.
"""
from .common import EffectParams
from .displace import Displace
from .explode import Explode
from .grade import Grade
from .morph import Morph, Pairing, pair
from .reveal import Reveal
from .stack import KERNELS, StackResult, apply_effect, evaluate_stack
from .twist import Twist

__all__ = ["EffectParams", "Displace", "Explode", "Grade", "Morph", "Pairing", "pair", "Reveal",
           "Twist", "KERNELS", "StackResult", "apply_effect", "evaluate_stack"]
