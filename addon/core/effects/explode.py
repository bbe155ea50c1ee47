"""Explode/Scatter: splats fly away from the gizmo's origin (CENTER) or along its +z
(DIRECTION), in closed form from time so any frame can be evaluated alone.

tau = max(0, time - start). Each splat i gets a seeded random unit vector r_i, a velocity
v_i = strength * normalize(d_i + spread * r_i) (d_i: unit radial or the gizmo's +z), and
p_i(tau) = p_i + amount * (v_i tau - 0.5 gravity tau^2 z_gizmo). It spins about a second
random axis at `spin` rad/s, and its opacity falls by exp(-fade tau).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .. import quaternion
from .common import (F32, EffectParams, for_blocks, frame_axis, frame_origin, join,
                     per_splat_random, split, unit_columns)
from .kind import SEED, EffectKind, Field

MODES = ("CENTER", "DIRECTION")


@dataclass
class Explode(EffectParams):
    mode: str = "CENTER"
    strength: float = 1.0   # object units per second
    spread: float = 0.3
    spin: float = 0.0       # radians per second
    gravity: float = 0.0    # object units per second^2, along the gizmo's -z
    start: float = 0.0      # seconds
    fade: float = 0.0       # per second
    seed: int = 0


def spin_axes(normals) -> list[np.ndarray]:
    """Unit spin axes (three columns) from a block of the seeded normals (salt 2)."""
    return unit_columns([c.copy() for c in normals])


def velocities(positions: np.ndarray, p: Explode, jitter) -> list[np.ndarray]:
    """Three velocity columns (object units per second); jitter: the block's three rows of
    seeded normals (salt 1)."""
    n = positions.shape[0]
    spread = F32(p.spread / np.sqrt(3.0))
    if p.mode == "CENTER":
        o = frame_origin(p.frame)
        d = split(positions)
        for i in range(3):
            d[i] -= F32(o[i])
        d = unit_columns(d)
    elif p.mode == "DIRECTION":
        axis = frame_axis(p.frame)
        d = [np.full(n, axis[i], F32) for i in range(3)]
    else:
        raise ValueError(f"Explode mode {p.mode!r} is not one of {MODES}")
    for i in range(3):
        d[i] += jitter[i] * spread
    v = unit_columns(d)
    for c in v:
        c *= F32(p.strength)
    return v


def apply(splats, p: Explode, time: float = 0.0, rest=None):
    tau = max(0.0, time - p.start)
    if not p.active or tau == 0.0 or splats.count == 0:
        return splats
    n = splats.count
    jitter = per_splat_random(n, p.seed, 1)
    normals = per_splat_random(n, p.seed, 2) if p.spin != 0.0 else None
    drop = frame_axis(p.frame) * (-0.5 * p.gravity * tau * tau * p.amount)
    half = 0.5 * p.spin * tau * p.amount  # every splat turns by this, about its own axis
    positions = np.empty_like(splats.positions)
    rotations = np.empty_like(splats.rotations) if normals is not None else None

    def block(part):
        centres = splats.positions[part]
        v = velocities(centres, p, jitter[:, part])
        start = split(centres)
        for i in range(3):
            v[i] *= F32(p.amount * tau)
            v[i] += F32(drop[i])
            v[i] += start[i]
        positions[part] = join(v)
        if rotations is not None:
            turn = [np.full(part.stop - part.start, np.cos(half), F32)]
            turn += [axis * F32(np.sin(half)) for axis in spin_axes(normals[:, part])]
            rotations[part] = quaternion.multiply(turn, splats.rotations[part])

    for_blocks(n, block)
    changes = {"positions": positions}
    if rotations is not None:
        changes["rotations"] = rotations
    if p.fade > 0.0:
        keep = 1.0 - p.amount * (1.0 - np.exp(-p.fade * tau))
        changes["opacities"] = splats.opacities * F32(keep)
    return replace(splats, **changes)


KIND = EffectKind(
    "EXPLODE", 2, "Explode/Scatter", "Splats fly away from a centre or along a direction",
    "MOD_EXPLODE", Explode, apply, writes=frozenset({"positions", "rotations", "opacities"}),
    moves_splats=True, depends_on_time=True, fields=(
        Field("explode_mode", "ENUM", "Mode", param="mode", items=(
            ("CENTER", "From Centre", "Away from the gizmo's origin"),
            ("DIRECTION", "Direction", "Along the gizmo's Z"))),
        Field("strength", "FLOAT", "Speed", 1.0, "Object units per second",
              options={"soft_min": 0.0, "soft_max": 10.0}),
        Field("spread", "FLOAT", "Spread", 0.3, options={"min": 0.0, "soft_max": 3.0}),
        Field("spin", "FLOAT", "Spin", 0.0, "Radians per second about a random axis",
              options={"soft_min": -20.0, "soft_max": 20.0}),
        Field("gravity", "FLOAT", "Gravity", 0.0, "Units per second squared along the gizmo's -Z",
              options={"soft_min": -20.0, "soft_max": 20.0}),
        Field("start_frame", "FLOAT", "Start Frame", 1.0, derived=True),
        Field("fade", "FLOAT", "Fade", 0.0, "Opacity decay per second after the start",
              options={"min": 0.0, "soft_max": 5.0}),
        SEED),
    derive=lambda values, fps: {"start": values["start_frame"] / fps})
