"""Displace: move each splat by a seeded, smooth noise vector that evolves in time.

The noise is sampled at the gizmo-local rest centre (the splat's position before the stack,
see stack.py) times `frequency` (lattice cells per unit), so the pattern stays on the splats.
It evolves by blending independent noise layers: with u = speed * time, k = floor(u) and
s = smoothstep(u - k), the field is (1 - s) N_k + s N_(k+1), divided by sqrt((1-s)^2 + s^2)
so its spread stays constant. That is continuous (C1) in time and a pure function of t.
The displacement is `amplitude` (object units) times the three channels, along the
object's axes. Because the spatial sampling never moves, each layer is evaluated once per
set of centres (noise.field memo): between layer changes a frame costs a blend.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .common import F32, EffectParams, for_blocks
from .kind import FREQUENCY, SEED, EffectKind, Field, GpuPath
from .noise import field_rows


@dataclass
class Displace(EffectParams):
    amplitude: float = 0.1
    frequency: float = 1.0
    speed: float = 0.5   # noise layers per second
    seed: int = 0


def layer_weights(speed: float, time: float) -> tuple[int, float, float]:
    """(k, weight of layer k, weight of layer k+1) at this time."""
    u = speed * time
    k = math.floor(u)
    s = u - k
    s = s * s * (3.0 - 2.0 * s)
    norm = math.sqrt((1.0 - s) ** 2 + s * s)
    return k, (1.0 - s) / norm, s / norm


def noise_layers(positions: np.ndarray, p: Displace, time: float):
    """(weight of layer k, its three channels), and the same for layer k+1 where its weight
    is not 0: the memoized noise at the rest centres."""
    k, w0, w1 = layer_weights(p.speed, time)
    layers = [(w0, field_rows(positions, p.frame, p.frequency, p.seed, 3, k))]
    if w1 != 0.0:
        layers.append((w1, field_rows(positions, p.frame, p.frequency, p.seed, 3, k + 1)))
    return layers


def apply(splats, p: Displace, time: float = 0.0, rest=None):
    if not p.active or p.amplitude == 0.0 or splats.count == 0:
        return splats
    layers = noise_layers(splats.positions if rest is None else rest, p, time)
    positions = np.empty_like(splats.positions)
    gain = F32(p.amount * p.amplitude)
    # block by block, so the blend's temporaries stay in cache; per value the same float32
    # operations as a whole-array (w0 a + w1 b) * gain + position
    (w0, first), *others = layers

    def block(part):
        c = first[part] * F32(w0)
        for w1, second in others:
            c += second[part] * F32(w1)
        c *= gain
        np.add(splats.positions[part], c, out=positions[part])

    for_blocks(splats.count, block)
    return replace(splats, positions=positions)


KIND = EffectKind(
    "DISPLACE", 1, "Displace", "Seeded smooth noise displacement, continuous in time", "MOD_NOISE",
    Displace, apply, writes=frozenset({"positions"}),
    gpu=GpuPath("displace"),
    moves_splats=True, depends_on_time=True, fields=(
        Field("amplitude", "FLOAT", "Amplitude", 0.1,
              options={"soft_min": 0.0, "soft_max": 2.0, "unit": "LENGTH"}),
        FREQUENCY,
        Field("speed", "FLOAT", "Speed", 0.5, "Noise cells per second the field drifts",
              options={"soft_min": -5.0, "soft_max": 5.0}),
        SEED))
