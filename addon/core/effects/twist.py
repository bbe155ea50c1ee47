"""Twist/Swirl around the gizmo's z axis (through its origin).

angle = amount * (twist * h + swirl * exp(-(r / radius)^2)), with h the gizmo-local height
and r the gizmo-local distance from the axis. Centres rotate rigidly about the axis in
object space and each splat's orientation turns with them.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .common import (F32, EffectParams, for_blocks, frame_axis, frame_origin, join, local_columns,
                     rotate_quats_about, split)
from .kind import EffectKind, Field


@dataclass
class Twist(EffectParams):
    twist: float = 1.0    # radians per gizmo-local unit along the axis
    swirl: float = 0.0    # radians at the axis, falling off with distance
    radius: float = 1.0   # swirl falloff, gizmo-local units


def angles(positions: np.ndarray, p: Twist) -> np.ndarray:
    if p.swirl == 0.0:
        (h,) = local_columns(positions, p.frame, (2,))
        h *= F32(p.twist * p.amount)
        return h
    x, y, h = local_columns(positions, p.frame)
    x *= x
    x += y * y
    x *= F32(-1.0 / max(p.radius, 1e-12) ** 2)
    swirl = np.exp(x, out=x)
    swirl *= F32(p.swirl)
    h *= F32(p.twist)
    h += swirl
    h *= F32(p.amount)
    return h


def rotate_about_axis(positions, origin, axis, cos, sin) -> np.ndarray:
    """Rodrigues' rotation of the centres about the line (origin, unit axis)."""
    o = origin.astype(F32)
    a = axis.astype(F32)
    v = split(positions)
    for i in range(3):
        v[i] -= o[i]
    along = v[0] * a[0]
    along += v[1] * a[1]
    along += v[2] * a[2]
    along *= F32(1.0) - cos
    cross = [a[1] * v[2] - a[2] * v[1], a[2] * v[0] - a[0] * v[2], a[0] * v[1] - a[1] * v[0]]
    for i in range(3):
        col = v[i]
        col *= cos
        cross[i] *= sin
        col += cross[i]
        col += along * a[i]
        col += o[i]
    return join(v)


def apply(splats, p: Twist, time: float = 0.0, rest=None):
    if not p.active or (p.twist == 0.0 and p.swirl == 0.0) or splats.count == 0:
        return splats
    origin, axis = frame_origin(p.frame), frame_axis(p.frame)
    positions = np.empty_like(splats.positions)
    rotations = np.empty_like(splats.rotations)

    def block(part):
        centres = splats.positions[part]
        half = angles(centres, p)
        half *= F32(0.5)
        sin_half = np.sin(half)
        cos_half = np.cos(half, out=half)
        # full-angle cos/sin from the half angle: two transcendental passes instead of four
        sin = sin_half * cos_half
        sin *= F32(2.0)
        cos = sin_half * sin_half
        cos *= F32(-2.0)
        cos += F32(1.0)
        positions[part] = rotate_about_axis(centres, origin, axis, cos, sin)
        rotations[part] = rotate_quats_about(axis, cos_half, sin_half, splats.rotations[part])

    for_blocks(splats.count, block)
    return replace(splats, positions=positions, rotations=rotations)


KIND = EffectKind(
    "TWIST", 3, "Twist/Swirl", "Rotate splats about an axis by height or radius", "MOD_SIMPLEDEFORM",
    Twist, apply, writes=frozenset({"positions", "rotations"}),
    moves_splats=True, depends_on_time=False, fields=(
        Field("twist", "FLOAT", "Twist", 0.5, "Angle per unit of height along the gizmo's Z",
              options={"subtype": "ANGLE"}),
        Field("swirl", "FLOAT", "Swirl", 0.0, "Angle at the axis, falling off with distance",
              options={"subtype": "ANGLE"}),
        Field("swirl_radius", "FLOAT", "Swirl Radius", 1.0, param="radius", options={"min": 0.0})))
