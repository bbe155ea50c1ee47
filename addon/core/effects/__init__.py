"""Per-splat effects: vectorised numpy kernels, the single source of truth for every renderer.

Each kernel is `apply(splats, params, time) -> SplatSet`: it never writes to its input and
returns a set that shares every array it did not change. Each effect describes itself with
an EffectKind beside its kernel (kind.py); registry.KINDS is the table of them.
"""
from .common import EffectParams
from .kind import EffectKind, Field
from .displace import Displace
from .explode import Explode
from .grade import Grade
from .morph import Morph, Pairing, pair
from .reveal import Reveal
from .registry import KINDS
from .stack import StackResult, apply_effect, evaluate_stack
from .twist import Twist

__all__ = ["EffectParams", "EffectKind", "Field", "KINDS", "Displace", "Explode", "Grade", "Morph",
           "Pairing", "pair", "Reveal", "Twist", "StackResult", "apply_effect", "evaluate_stack"]
