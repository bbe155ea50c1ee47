"""The table of effects: one row (an EffectKind, declared beside its kernel) per effect.

The stack, the Blender property group, its panel and menus, and the evaluator all read
this table; an effect added with `add` is offered and evaluated everywhere once the
Blender layer registers again (the property group is built from the table then).
"""
from __future__ import annotations

from . import displace, explode, grade, morph, reveal, twist
from .kind import FREQUENCY, SEED, EffectKind

KINDS: dict[str, EffectKind] = {}

# Settings several kinds share come first in the property group, as they always have
# (saved presets list the properties in that order).
SHARED_FIELDS = (SEED, FREQUENCY)


def add(kind: EffectKind) -> None:
    """Add a row; one line naming the clash when its id, number, params class or a field
    that another kind declares differently collides with the table."""
    for other in KINDS.values():
        for what, mine, theirs in (("id", kind.id, other.id), ("number", kind.number, other.number),
                                   ("params", kind.params, other.params)):
            if mine == theirs:
                raise ValueError(f"effect {kind.id}: {what} {mine!r} is already {other.id}'s")
    declared = {f.name: f for f in all_fields()}
    for f in kind.fields:
        if f.name in declared and declared[f.name] != f:
            raise ValueError(f"effect {kind.id}: field {f.name!r} differs from the one "
                             "another effect declares (a shared property must be one Field)")
    KINDS[kind.id] = kind


def remove(kind_id: str) -> None:
    del KINDS[kind_id]


def of(params) -> EffectKind:
    """The kind whose params class `params` is."""
    for kind in KINDS.values():
        if type(params) is kind.params:
            return kind
    raise TypeError(f"no effect kernel for {type(params).__name__}")


def all_fields() -> list:
    """Every field of every kind once, shared ones first, then in table order."""
    out = {f.name: f for f in SHARED_FIELDS}
    for kind in KINDS.values():
        for f in kind.fields:
            out.setdefault(f.name, f)
    return list(out.values())


for _kind in (reveal.KIND, displace.KIND, explode.KIND, twist.KIND, grade.KIND, morph.KIND):
    add(_kind)
