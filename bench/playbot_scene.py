"""A generated stand-in for a ~500k-splat capture like PlayCanvas' "playbot": a figure
(ellipsoid body, head, limbs) standing in a room whose walls, floor and ceiling fill the
frame, degree-2 SH. Dense like a real capture: most pixels of the 1080p frame saturate
(transmittance < 1e-4) long before their last splat, which is what the final-frame bench
is about. Deterministic for a seed.
"""
from __future__ import annotations

import numpy as np

from addon.core.camera import look_at, simple_camera
from addon.core.scene import RenderItem
from addon.core.splats import SplatSet

# (centre, radii) of the figure's ellipsoids, metres, z up
PARTS = (((0.0, 0.0, 1.0), (0.28, 0.2, 0.38)),      # body
         ((0.0, 0.0, 1.62), (0.2, 0.2, 0.2)),       # head
         ((-0.42, 0.0, 1.05), (0.09, 0.09, 0.32)),  # arms
         ((0.42, 0.0, 1.05), (0.09, 0.09, 0.32)),
         ((-0.14, 0.0, 0.33), (0.1, 0.1, 0.34)),    # legs
         ((0.14, 0.0, 0.33), (0.1, 0.1, 0.34)))
ROOM = (3.0, 3.0, 2.6)  # half width (x), half depth (y), height


def _fill(s: SplatSet, rng, pos: np.ndarray, normal: np.ndarray, size: float, base_rgb):
    """Flat-ish splats (thin along the surface normal) at pos, opacity mostly high."""
    n = len(pos)
    s.positions[:] = pos
    tangent = np.exp(rng.normal(np.log(size), 0.45, (n, 2)))
    s.scales[:] = np.column_stack([tangent, 0.15 * tangent.min(1)])
    # rotation taking local z to the normal (plus a random spin about it)
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, normal)
    sin = np.linalg.norm(axis, axis=1)
    cos = normal @ z
    half = 0.5 * np.arctan2(sin, cos)
    axis = np.where(sin[:, None] > 1e-9, axis / np.maximum(sin, 1e-9)[:, None], [1.0, 0.0, 0.0])
    q = np.column_stack([np.cos(half), axis * np.sin(half)[:, None]])
    spin = rng.uniform(0, np.pi, n)
    qs = np.column_stack([np.cos(spin), np.zeros(n), np.zeros(n), np.sin(spin)])
    s.rotations[:] = _qmul(q, qs)
    s.opacities[:] = np.where(rng.random(n) < 0.8, rng.beta(8, 1, n), rng.beta(1, 3, n))
    rgb = np.asarray(base_rgb) + 0.25 * np.sin(pos * [7.0, 5.0, 9.0]) + rng.normal(0, 0.06, (n, 3))
    s.sh_dc[:] = (np.clip(rgb, 0.02, 0.98) - 0.5) / 0.28209479177387814
    s.sh_rest[:] = rng.normal(0.0, 0.06, s.sh_rest.shape)


def _qmul(a, b):
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.column_stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def figure(n: int, rng) -> SplatSet:
    s = SplatSet.allocate(n, 2)
    vol = np.array([np.prod(r) ** (2 / 3) for _, r in PARTS])  # ~ surface area
    which = rng.choice(len(PARTS), n, p=vol / vol.sum())
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    centre = np.array([PARTS[k][0] for k in which])
    radii = np.array([PARTS[k][1] for k in which])
    depth = 1.0 - np.abs(rng.normal(0.0, 0.04, (n, 1)))  # a shell a few cm thick
    pos = centre + d * radii * depth
    normal = d / radii
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    _fill(s, rng, pos, normal, 0.008, (0.85, 0.55, 0.2))
    return s


def room(n: int, rng) -> SplatSet:
    """Floor, ceiling and four walls, splats on the surfaces facing inwards."""
    s = SplatSet.allocate(n, 2)
    hx, hy, hz = ROOM
    areas = np.array([4 * hx * hy, 4 * hx * hy, 2 * hx * hz, 2 * hx * hz, 2 * hy * hz, 2 * hy * hz])
    face = rng.choice(6, n, p=areas / areas.sum())
    u, v = rng.random(n), rng.random(n)
    pos = np.empty((n, 3))
    normal = np.zeros((n, 3))
    x, y, z = (u * 2 - 1) * hx, (v * 2 - 1) * hy, v * hz
    for k, (p, nrm) in enumerate((((x, y, 0.0 * u), (0, 0, 1)), ((x, y, hz + 0 * u), (0, 0, -1)),
                                  ((x, -hy + 0 * u, z), (0, 1, 0)), ((x, hy + 0 * u, z), (0, -1, 0)),
                                  ((-hx + 0 * u, (u * 2 - 1) * hy, z), (1, 0, 0)),
                                  ((hx + 0 * u, (u * 2 - 1) * hy, z), (-1, 0, 0)))):
        m = face == k
        pos[m] = np.column_stack(p)[m]
        normal[m] = nrm
    pos += normal * rng.normal(0.0, 0.01, (n, 1))
    _fill(s, rng, pos, normal, 0.03, (0.45, 0.5, 0.55))
    return s


def scene(count: int = 500_000, width: int = 1920, height: int = 1080, seed: int = 0):
    """([figure, room] items, camera): 60% of the splats on the figure, 40% in the room."""
    rng = np.random.default_rng(seed)
    n_fig = int(count * 0.6)
    items = [RenderItem(figure(n_fig, rng), key=("playbot", 0)),
             RenderItem(room(count - n_fig, rng), key=("room", 0))]
    cam = simple_camera(width, height, 60.0, look_at((0.3, -2.4, 1.3), (0.0, 0.0, 1.0)),
                        near=0.05, far=50.0)
    return items, cam
