"""Look > Lighting (issue 43): how well per-splat normals find a known surface, and what a lit
frame costs against an unlit one.

    python -m bench.lighting_bench [--splats 500000] [--frames 3]

Normals: generated captures whose surface is known. A unit sphere and a plane of flat splats
(scales 0.02, 0.02, 0.002) whose thin axis is the surface normal turned by a random tilt of
0 or 10 degrees (a trained capture's noise), and near-isotropic splats (third scale 0.9-1.0 of
the others, turned at random: nothing in them says where the surface is) on the same plane.
Printed: the median and 95th-percentile angle between each normal's line
(core/lighting/normals.py) and the surface's, and the share of splats each orientation rule
turns to the wrong side (the side the eye does not see).

Speed: N random splats in a 2 m box, 1920x1080, the GL offscreen renderer (addon/gl). Unlit:
the same item frame after frame (its upload kept). Lit: each frame the light moves, so the
splats are relit (core/lighting/shade.py) and their colours uploaded again; with a shadow,
also a mesh of 3,072 triangles (a cube cut into a grid) and the splats' transmittance map
(core/lighting/shadows.py). Medians of the frames, ratios against unlit.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import replace

import numpy as np

from addon.core.camera import look_at, simple_camera
from addon.core.lighting import shadows
from addon.core.lighting.lights import Light
from addon.core.lighting.normals import splat_normals
from addon.core.lighting.shade import Lighting, lit_splats
from addon.core.quaternion import from_matrix
from addon.core.scene import RenderItem
from testing.synth import random_splats


def _frames_towards(normals: np.ndarray, tilt_deg: float, rng) -> np.ndarray:
    """wxyz rotations whose local z is each normal tilted by tilt_deg in a random direction."""
    n = len(normals)
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    u = np.cross(normals, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(normals, u)
    phi = rng.uniform(0, 2 * np.pi, n)
    t = np.radians(tilt_deg)
    z = np.cos(t) * normals + np.sin(t) * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v)
    x = np.cross(v, z)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(z, x)
    return from_matrix(np.stack([x, y, z], axis=2))


def _case(shape: str, tilt: float, round_: bool, n: int = 50_000, seed: int = 1):
    rng = np.random.default_rng(seed)
    s = random_splats(n, degree=0, seed=seed)
    if shape == "sphere":
        p = rng.normal(size=(n, 3))
        p /= np.linalg.norm(p, axis=1, keepdims=True)
        true = p.copy()
    else:
        p = np.c_[rng.uniform(-1, 1, (n, 2)), np.zeros(n)]
        true = np.tile([0.0, 0.0, 1.0], (n, 1))
    s.positions[:] = p
    s.rotations[:] = _frames_towards(true, tilt, rng)
    third = np.full(n, 0.002)
    if round_:  # a round splat's rotation says nothing of the surface: any turn, any short axis
        s.rotations[:] = rng.normal(size=(n, 4))
        third = rng.uniform(0.018, 0.02, n)
    s.scales[:] = np.c_[np.full(n, 0.02), np.full(n, 0.02), third]
    return s, p, true


def normals_rows() -> None:
    """Axis error (the normal's line against the surface's, sign apart) and, of the splats
    the eye sees on the surface's outside, the share each rule turns away from it: towards
    the eye (Splatline's), or away from the capture's centre."""
    eye = np.array([0.3, -0.4, 3.0])
    print(f"{'capture':46} {'median':>7} {'p95':>7}  wrong side: eye  centre")
    for shape, tilt, round_ in (("sphere", 0, False), ("sphere", 10, False), ("plane", 0, False),
                                ("plane", 10, False), ("plane", 0, True)):
        s, p, true = _case(shape, tilt, round_)
        _, got = splat_normals(s, np.eye(4), eye)
        cos = np.einsum("ij,ij->i", got, true)
        angle = np.degrees(np.arccos(np.clip(np.abs(cos), 0, 1)))
        front = np.einsum("ij,ij->i", true, eye - p) > 0   # the splats a solid shows the eye
        wrong_eye = np.mean(cos[front] < 0)
        outward = np.sign(np.einsum("ij,ij->i", got, p - p.mean(axis=0)))
        wrong_centre = np.mean((cos * outward)[front] <= 0)
        label = f"{shape}, {'near-isotropic' if round_ else 'flat'} splats, tilt {tilt} deg"
        print(f"{label:46} {np.median(angle):7.2f} {np.percentile(angle, 95):7.2f}"
              f"  {100 * wrong_eye:13.1f}% {100 * wrong_centre:6.1f}%")


def _cube_grid(cells: int = 16) -> np.ndarray:
    """A cube of side 0.4 above the box, each face cut into cells x cells quads (12 x cells^2 triangles)."""
    t = np.linspace(-0.2, 0.2, cells + 1)
    tris = []
    for axis in range(3):
        for side in (-0.2, 0.2):
            a, b = np.meshgrid(t, t)
            grid = np.zeros(a.shape + (3,))
            grid[..., axis] = side
            grid[..., (axis + 1) % 3], grid[..., (axis + 2) % 3] = a, b
            p00, p10, p01, p11 = grid[:-1, :-1], grid[1:, :-1], grid[:-1, 1:], grid[1:, 1:]
            tris += [np.stack([p00, p10, p11], -2).reshape(-1, 3, 3), np.stack([p00, p11, p01], -2).reshape(-1, 3, 3)]
    return np.concatenate(tris) + [0.0, 0.0, 1.5]


def speed_rows(count: int, frames: int) -> None:
    from addon.gl import OffscreenRenderer

    s = random_splats(count, degree=3, seed=2)
    world = np.eye(4)
    item = RenderItem(splats=s, world=world, key=("bench", 0))
    camera = simple_camera(1920, 1080, 50.0, look_at(np.array([0.0, -4.0, 2.0]), np.zeros(3)))
    triangles = _cube_grid()
    renderer = OffscreenRenderer(depth_pass=False)
    renderer.render([item], camera)
    times = {"unlit": [], "lit": [], "lit + 1 shadowed light": []}
    for f in range(frames + 1):
        light = Light("SPOT", (np.cos(f), np.sin(f), 3.0), (0.0, 0.0, -1.0), power=500.0, spot_size=1.5)
        lighting = Lighting((light,), (0.05, 0.05, 0.05), (0.0, -4.0, 2.0))
        for name in times:
            start = time.perf_counter()
            if name == "unlit":
                renderer.render([item], camera)
            else:
                vis = None
                if name != "lit":
                    points = s.positions.astype(np.float64)
                    vis = [shadows.light_visibility(points, light, triangles, s, world)]
                lit = lit_splats(s, world, lighting, 1.0, vis)
                renderer.render([replace(item, splats=lit, key=("bench", f, name))], camera)
            if f:  # the first round warms up
                times[name].append(time.perf_counter() - start)
    base = statistics.median(times["unlit"])
    print(f"{count:,} splats (degree 3), 1920x1080, GL offscreen; {len(triangles):,} shadow triangles")
    for name, values in times.items():
        m = statistics.median(values)
        print(f"{name:26} {m * 1e3:9.1f} ms  {m / base:5.2f}x unlit")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--splats", type=int, default=500_000)
    parser.add_argument("--frames", type=int, default=3)
    args = parser.parse_args(argv if argv is not None else [])
    normals_rows()
    speed_rows(args.splats, args.frames)


if __name__ == "__main__":
    main(sys.argv[1:])
