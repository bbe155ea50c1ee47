"""What every effect kernel shares: its common parameters, the gizmo frame, small math.

Kernels take a read-only SplatSet and return a new one that shares every array they did
not change (copy-on-write): a colour-only effect hands back the very same positions array,
so the sort keys of the renderers stay valid.

The gizmo frame is a 4x4 matrix from gizmo-local to splat-object coordinates (the Empty's
matrix relative to the splat object). Fields (height, distance, plane, noise) are measured
in gizmo-local units, so scaling the Empty scales the field; motions (explode, twist) are
rigid in object space, around the gizmo's origin and its normalized axes.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

F32 = np.float32


@dataclass
class EffectParams:
    enabled: bool = True
    amount: float = 1.0                      # blend: 0 = no effect, 1 = full effect
    frame: np.ndarray = field(default_factory=lambda: np.eye(4))

    @property
    def active(self) -> bool:
        return self.enabled and self.amount > 0.0


def is_identity(m: np.ndarray) -> bool:
    return bool(np.array_equal(m, np.eye(4)))


def local_columns(positions: np.ndarray, frame: np.ndarray, axes=(0, 1, 2)) -> list[np.ndarray]:
    """Gizmo-local coordinates of the centres, one contiguous float32 column per axis asked."""
    cols = [positions[:, 0], positions[:, 1], positions[:, 2]]
    if is_identity(frame):
        return [np.ascontiguousarray(cols[a]) for a in axes]
    inv = np.linalg.inv(np.asarray(frame, np.float64))
    out = []
    for a in axes:
        row = inv[a]
        acc = cols[0] * F32(row[0])
        acc += cols[1] * F32(row[1])
        acc += cols[2] * F32(row[2])
        acc += F32(row[3])
        out.append(acc)
    return out


def frame_origin(frame: np.ndarray) -> np.ndarray:
    return np.asarray(frame, np.float64)[:3, 3].copy()


def frame_axis(frame: np.ndarray, axis: int = 2) -> np.ndarray:
    """Unit direction of a gizmo axis in object space (+z by default)."""
    v = np.asarray(frame, np.float64)[:3, axis]
    n = np.linalg.norm(v)
    return v / n if n > 0 else np.eye(3)[axis]


def smoothstep01(s: np.ndarray) -> np.ndarray:
    """3s^2 - 2s^3 for s already clipped to [0, 1], in place on s."""
    t = s * s
    s *= F32(-2.0)
    s += F32(3.0)
    s *= t
    return s


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a*b of (N, 4) wxyz quaternions (applies b, then a)."""
    aw, ax, ay, az = (a[:, i] for i in range(4))
    bw, bx, by, bz = (b[:, i] for i in range(4))
    out = np.empty(np.broadcast_shapes(a.shape, b.shape), F32)
    out[:, 0] = aw * bw - ax * bx - ay * by - az * bz
    out[:, 1] = aw * bx + ax * bw + ay * bz - az * by
    out[:, 2] = aw * by - ax * bz + ay * bw + az * bx
    out[:, 3] = aw * bz + ax * by - ay * bx + az * bw
    return out


def axis_angle_quats(axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """(N, 4) quaternions rotating by angles (N,) about unit axes ((N, 3) or (3,))."""
    half = (angles * F32(0.5)).astype(F32, copy=False)
    out = np.empty((half.shape[0], 4), F32)
    out[:, 0] = np.cos(half)
    s = np.sin(half)
    axes = np.asarray(axes, F32)
    if axes.ndim == 1:
        for i in range(3):
            out[:, i + 1] = s * axes[i]
    else:
        out[:, 1:] = axes * s[:, None]
    return out


def per_splat_random(n: int, seed: int, salt: int) -> np.ndarray:
    """(n, 3) float32 standard normals, a pure function of (n, seed, salt)."""
    key = (n, seed, salt)
    hit = _RANDOM_CACHE.get(key)
    if hit is None:
        rng = np.random.default_rng([seed & 0xFFFFFFFF, salt])
        hit = rng.standard_normal((n, 3), dtype=np.float32)
        hit.flags.writeable = False
        _RANDOM_CACHE[key] = hit
        while len(_RANDOM_CACHE) > 4:
            _RANDOM_CACHE.pop(next(iter(_RANDOM_CACHE)))
    return hit


# A pure cache (results never depend on it), bounded to a few arrays.
_RANDOM_CACHE: dict = {}
