"""Displace: move each splat by a seeded, smooth noise vector.

The noise is sampled at the gizmo-local position times `frequency` (lattice cells per unit),
and the field drifts through the capture at `speed` cells per second along a fixed
direction, so the result is continuous in time and a pure function of t. The displacement
is `amplitude` (object units) times the three noise channels, along the object's axes.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .common import F32, EffectParams, local_columns
from .noise import value_noise

DRIFT = np.array([0.48, 0.6, 0.64])  # unit direction the field drifts along


@dataclass
class Displace(EffectParams):
    amplitude: float = 0.1
    frequency: float = 1.0
    speed: float = 0.5
    seed: int = 0


def noise_vectors(positions: np.ndarray, p: Displace, time: float) -> list[np.ndarray]:
    cols = local_columns(positions, p.frame)
    f = F32(p.frequency)
    shift = DRIFT * (p.speed * time)
    for axis, col in enumerate(cols):
        col *= f
        col += F32(shift[axis])
    return value_noise(cols[0], cols[1], cols[2], p.seed, channels=3)


def apply(splats, p: Displace, time: float = 0.0):
    if not p.active or p.amplitude == 0.0 or splats.count == 0:
        return splats
    noise = noise_vectors(splats.positions, p, time)
    positions = np.empty_like(splats.positions)
    gain = F32(p.amount * p.amplitude)
    for axis in range(3):
        np.multiply(noise[axis], gain, out=noise[axis])
        np.add(splats.positions[:, axis], noise[axis], out=positions[:, axis])
    return replace(splats, positions=positions)
