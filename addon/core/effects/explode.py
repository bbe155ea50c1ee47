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

from .common import (F32, EffectParams, axis_angle_quats, frame_axis, frame_origin,
                     per_splat_random, quat_multiply)

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


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.sqrt(np.einsum("ij,ij->i", v, v))
    np.maximum(n, F32(1e-12), out=n)
    v /= n[:, None]
    return v


def velocities(positions: np.ndarray, p: Explode) -> np.ndarray:
    n = positions.shape[0]
    jitter = per_splat_random(n, p.seed, 1)
    if p.mode == "CENTER":
        d = _unit(positions - frame_origin(p.frame).astype(F32))
    elif p.mode == "DIRECTION":
        d = np.broadcast_to(frame_axis(p.frame).astype(F32), (n, 3))
    else:
        raise ValueError(f"Explode mode {p.mode!r} is not one of {MODES}")
    v = _unit(d + jitter * F32(p.spread / np.sqrt(3.0)))
    v *= F32(p.strength)
    return v


def apply(splats, p: Explode, time: float = 0.0):
    tau = max(0.0, time - p.start)
    if not p.active or tau == 0.0 or splats.count == 0:
        return splats
    v = velocities(splats.positions, p)
    v *= F32(p.amount * tau)
    drop = frame_axis(p.frame) * (-0.5 * p.gravity * tau * tau * p.amount)
    v += drop.astype(F32)
    v += splats.positions
    changes = {"positions": v}
    if p.spin != 0.0:
        axes = _unit(per_splat_random(splats.count, p.seed, 2).copy())
        angle = np.full(splats.count, p.spin * tau * p.amount, F32)
        changes["rotations"] = quat_multiply(axis_angle_quats(axes, angle), splats.rotations)
    if p.fade > 0.0:
        keep = 1.0 - p.amount * (1.0 - np.exp(-p.fade * tau))
        changes["opacities"] = splats.opacities * F32(keep)
    return replace(splats, **changes)
