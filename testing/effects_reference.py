"""The effect kernels as they stood at 09da160, before the fast paths: readable numpy, one
block (or one whole array) at a time on one thread. tests/core/effects/test_effects_fast_paths.py pins
the kernels in addon/core/effects to these (bit for bit, or within the bound it states)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from addon.core.effects import displace as displace_module
from addon.core.effects.common import (F32, add_rows, blocks, field_values, join, scale_rows,
                                       smoothstep01, split)
from addon.core.effects.grade import grade_block  # its per-block maths did not change
from addon.core.effects.noise import field, rest_field
from addon.core.sh import C0

_FIELD = {"PLANE": "HEIGHT", "SPHERE": "DISTANCE", "NOISE": "NOISE"}


def field_blocks(positions, frame, kind, noise=None):
    for part in blocks(len(positions)):
        yield part, field_values(positions[part], frame, kind, None if noise is None else noise[part])


def reveal_edge(f: np.ndarray, p: Reveal) -> np.ndarray:
    """s in [0, 1]: 1 well inside the shown side, 0 well outside, 0.5 at the threshold."""
    if p.width <= 0.0:
        return (f < F32(p.progress)).astype(F32)
    s = f  # f is a fresh array owned here
    s -= F32(p.progress)
    s *= F32(-1.0 / p.width)
    s += F32(0.5)
    return np.clip(s, 0.0, 1.0, out=s)


def reveal(splats, p, time: float = 0.0, rest=None):
    if not p.active or splats.count == 0:
        return splats
    noise = rest_field(splats, rest, p) if p.shape == "NOISE" else None
    opacities = np.empty_like(splats.opacities)
    scales = np.empty_like(splats.scales) if p.shrink > 0.0 else None
    sh_dc = np.empty_like(splats.sh_dc) if p.glow_strength > 0.0 else None
    for part, f in field_blocks(splats.positions, p.frame, _FIELD[p.shape], noise):
        s = reveal_edge(f, p)
        if sh_dc is not None:
            glow = s * (F32(1.0) - s)
            glow *= F32(4.0 * p.amount * p.glow_strength / C0)
            sh_dc[part] = add_rows(splats.sh_dc[part], p.glow_color, glow)
        hidden = smoothstep01(s)  # visibility, in place
        if not p.invert:
            hidden -= F32(1.0)
            hidden *= F32(-1.0)
        # hidden = 1 - visibility; opacity factor = 1 - amount * hidden
        fade = hidden * F32(-p.amount)
        fade += F32(1.0)
        np.multiply(splats.opacities[part], fade, out=opacities[part])
        if scales is not None:
            hidden *= F32(-p.amount * p.shrink)
            hidden += F32(1.0)
            scales[part] = scale_rows(splats.scales[part], hidden)
    changes = {"opacities": opacities}
    if scales is not None:
        changes["scales"] = scales
    if sh_dc is not None:
        changes["sh_dc"] = sh_dc
    return replace(splats, **changes)


def grade(splats, p, time: float = 0.0, rest=None):
    if not p.active or not p.stops or splats.count == 0:
        return splats
    noise = rest_field(splats, rest, p) if p.field == "NOISE" else None
    dc = np.empty_like(splats.sh_dc)
    for part, x in field_blocks(splats.positions, p.frame, p.field, noise):
        grade_block(splats.sh_dc[part], x, p, dc[part])
    return replace(splats, sh_dc=dc)


def noise_vectors(positions: np.ndarray, p: Displace, time: float) -> list[np.ndarray]:
    k, w0, w1 = displace_module.layer_weights(p.speed, time)
    first = field(positions, p.frame, p.frequency, p.seed, 3, k)
    if w1 == 0.0:
        return [c * F32(w0) for c in first]
    second = field(positions, p.frame, p.frequency, p.seed, 3, k + 1)
    out = []
    for a, b in zip(first, second):
        c = a * F32(w0)
        c += b * F32(w1)
        out.append(c)
    return out


def displace(splats, p, time: float = 0.0, rest=None):
    if not p.active or p.amplitude == 0.0 or splats.count == 0:
        return splats
    noise = noise_vectors(splats.positions if rest is None else rest, p, time)
    positions = np.empty_like(splats.positions)
    gain = F32(p.amount * p.amplitude)
    for axis in range(3):
        noise[axis] *= gain
        np.add(splats.positions[:, axis], noise[axis], out=positions[:, axis])
    return replace(splats, positions=positions)


def slerp(q0: np.ndarray, q1: np.ndarray, t: float) -> np.ndarray:
    """Shortest-arc slerp of (N, 4) quaternions; nlerp where they nearly coincide
    (sin(theta) < 1e-5), where slerp's weights lose precision."""
    a, b = split(q0), split(q1)
    dot = a[0] * b[0]
    for i in range(1, 4):
        dot += a[i] * b[i]
    sign = np.copysign(F32(1.0), dot)
    np.abs(dot, out=dot)
    np.minimum(dot, F32(1.0), out=dot)
    theta = np.arccos(dot)
    sin = np.sin(theta)
    near = sin < 1e-5
    sin[near] = 1.0
    w0 = np.sin(theta * F32(1.0 - t))
    w0 /= sin
    w1 = np.sin(theta * F32(t))
    w1 /= sin
    w0[near] = 1.0 - t
    w1[near] = t
    w1 *= sign
    norm = np.zeros_like(dot)
    for i in range(4):
        a[i] *= w0
        a[i] += b[i] * w1
        norm += a[i] * a[i]
    np.sqrt(norm, out=norm)
    np.maximum(norm, F32(1e-12), out=norm)
    np.divide(F32(1.0), norm, out=norm)
    for col in a:
        col *= norm
    return join(a)
