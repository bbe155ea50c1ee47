"""Effect presets: a named effect stack with keyframes relative to the frame it is applied at.

A preset is JSON (presets/effects/*.json):

    {"label": "Sweep Reveal", "description": "...",
     "look":    {"set": {...}, "keys": {"opacity": [[0, 0.0], [24, 1.0]]}},
     "effects": [{"type": "REVEAL", "set": {"reveal_shape": "PLANE"},
                  "keys": {"progress": [[0, "zmin - 0.1"], [48, "zmax + 0.1"]]},
                  "interpolation": "BEZIER"}]}

Key frames are offsets from the current frame. A value may be a number, a string, a list,
or an arithmetic expression over the object's bounds (zmin, zmax, zlow, zhigh, radius, size)
and `frame` (the frame the preset is applied at), so one preset fits captures of any size.
Bounds are measured where the preset's fields measure: in the frame of a field without a gizmo
(world-aligned axes at the object's origin, world units), not in the object's own axes, which
an import's axis convention (or any rotation, scale or parent) turns away from the world's.
This module is pure: parsing, validation and value resolution; applying is the Blender layer's.
"""
from __future__ import annotations

import ast
import json
import operator
import pathlib
from dataclasses import dataclass, field

from .effects import registry

INTERPOLATIONS = ("CONSTANT", "LINEAR", "BEZIER")
NAMES = ("zmin", "zmax", "zlow", "zhigh", "radius", "size", "frame")


class PresetError(ValueError):
    """A preset file that cannot be used; the message names the file."""


@dataclass
class Block:
    """Settings and keyframes for one property group (the look, or one effect)."""
    set: dict = field(default_factory=dict)
    keys: dict = field(default_factory=dict)  # property -> [(frame offset, value), ...]
    interpolation: str = "BEZIER"
    type: str | None = None  # effect type; None for the look block

    @property
    def target_field(self) -> str | None:
        """The field of this effect that takes a second splat object (None: none, or the look)."""
        kind = registry.KINDS.get(self.type)
        return kind.target_field if kind is not None else None


@dataclass
class EffectPreset:
    name: str
    label: str
    description: str
    look: Block | None
    effects: list[Block]

    @property
    def needs_target(self) -> bool:
        """Whether applying it asks for a second splat object (a morph's target)."""
        return any(block.target_field for block in self.effects)


def load(path) -> EffectPreset:
    path = pathlib.Path(path)
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise PresetError(f"{path}: {exc}") from None
    try:
        return parse(path.stem, data)
    except (KeyError, TypeError, ValueError) as exc:
        raise PresetError(f"{path}: {exc}") from None


def parse(name: str, data: dict) -> EffectPreset:
    look = _block(data["look"], None) if "look" in data else None
    effects = [_block(e, e["type"]) for e in data.get("effects", [])]
    if look is None and not effects:
        raise ValueError("a preset needs a 'look' block or at least one effect")
    return EffectPreset(name, data.get("label", name.replace("_", " ").title()),
                        data.get("description", ""), look, effects)


def _block(data: dict, effect_type) -> Block:
    unknown = set(data) - {"type", "set", "keys", "interpolation"}
    if unknown:
        raise ValueError(f"unknown fields {sorted(unknown)}")
    interpolation = data.get("interpolation", "BEZIER")
    if interpolation not in INTERPOLATIONS:
        raise ValueError(f"interpolation {interpolation!r} is not one of {INTERPOLATIONS}")
    keys = {}
    for prop, points in data.get("keys", {}).items():
        keys[prop] = [(float(offset), value) for offset, value in points]
        if not keys[prop]:
            raise ValueError(f"keys for {prop!r} are empty")
    return Block(dict(data.get("set", {})), keys, interpolation, effect_type)


def resolve(value, context: dict):
    """A preset value with expressions evaluated against context (see NAMES)."""
    if isinstance(value, str) and _is_expression(value):
        return _eval(ast.parse(value, mode="eval").body, context)
    if isinstance(value, list):
        return [resolve(v, context) for v in value]
    return value


def _is_expression(text: str) -> bool:
    return any(name in text for name in NAMES) or text.strip()[:1] in "-+0123456789.("


_OPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
        ast.Div: operator.truediv, ast.USub: operator.neg, ast.UAdd: operator.pos}


def _eval(node, context):
    """Arithmetic only: numbers, the names in NAMES, + - * / and parentheses."""
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
        return float(node.value)
    if isinstance(node, ast.Name) and node.id in context:
        return float(context[node.id])
    if isinstance(node, ast.BinOp) and type(node.op) in _OPS:
        return _OPS[type(node.op)](_eval(node.left, context), _eval(node.right, context))
    if isinstance(node, ast.UnaryOp) and type(node.op) in _OPS:
        return _OPS[type(node.op)](_eval(node.operand, context))
    raise ValueError(f"unsupported expression {ast.unparse(node)!r}; use numbers, {NAMES}, + - * /")


def bounds_context(positions, frame: float, field=None) -> dict:
    """Bounds of a splat object in a field's frame (field: 4x4, object <- field; None: the
    object's own axes). zmin/zmax: robust 1st/99th percentiles of the field's z, for pacing
    a sweep past stray floaters; zlow/zhigh: the exact extremes, which a sweep must pass for
    every splat to reach its end state; radius and size."""
    import numpy as np

    if len(positions) == 0:
        return {"zmin": 0.0, "zmax": 0.0, "zlow": 0.0, "zhigh": 0.0, "radius": 1.0, "size": 1.0,
                "frame": float(frame)}
    positions = np.asarray(positions, np.float64)
    if field is not None:
        to_field = np.linalg.pinv(np.asarray(field, np.float64))
        positions = positions @ to_field[:3, :3].T + to_field[:3, 3]
    positions = positions[np.isfinite(positions).all(axis=1)]
    z = positions[:, 2]
    lo, hi = np.percentile(positions, 1, axis=0), np.percentile(positions, 99, axis=0)
    centre = 0.5 * (lo + hi)
    radius = float(np.percentile(np.linalg.norm(positions - centre, axis=1), 99))
    return {"zmin": float(np.percentile(z, 1)), "zmax": float(np.percentile(z, 99)),
            "zlow": float(z.min()), "zhigh": float(z.max()),
            "radius": radius, "size": float(np.max(hi - lo)), "frame": float(frame)}
