"""Splats and meshes in one frame (issue 25): what holding meshes out costs the offscreen
renderer, at 1920x1080 on the final-frame bench's ~500,000-splat capture
(bench/playbot_scene.py, as final_frame_bench.py renders it).

    python -m bench holdout        (or make bench)
    python -m bench.holdout_bench [runs]

The mesh, 10,560 triangles (mesh()): a UV sphere between the camera and the figure,
covering its right arm and shoulder, and a subdivided plane through the figure's
middle, turned against the view (per fragment it hides only the splats behind it); the
share of the frame it covers is printed above the table, with how the GL renderer's
surface map compares with core.holdout_depth's.
Rows: the colour frame, and the frame with the Z pass. Columns: without a holdout; with
the mesh (goal: with / without <= 1.10); and with the same mesh moved 1.6 m to the
right, so that only a sliver of the sphere at the frame's edge is in view ("edge", 1.3%
of the frame: every cost of a holdout frame, the map, the depth buffer and its test, the
batch minima, and little hidden to gain from; a mesh wholly out of view costs nothing,
the plain programs run). Wall ms, CPU ms of all threads (llvmpipe's included) in brackets, medians of RUNS
frames after a warm-up (shaders, uploads: the triangles are sent once per Holdout.key,
so every timed frame finds them resident), the three interleaved in one process (their
order rotating run by run). Under the table: the surface map alone
(renderer.holdout_depth, read back included), and PSNR / max abs of the held-out colour
frame against the float64 reference with the same holdout over WINDOWS (128x128 crops,
rendered by the reference exactly as parts of the frame from the splats that reach
them), early termination on both sides (INRIA's exact stop in the reference, as
final_frame_bench's "PSNR ET"), and off on both. Their max abs (3.0e-2, a few pixels
where the plane cuts the figure's shell) is a splat whose centre lies within float32
rounding of the plane (1e-7 relative) landing on the other side of it: a per-fragment
read of the float32 map instead of the depth test had the same largest error (3 pixels
over 1e-3 in the plane's window; the encoded depth test 7, adding splats within
held_band of the plane, gl/holdout.py: 4.3 um here).

A run on the shared 2-core llvmpipe VM (2026-11-26, 7 frames): colour 1260 ms without,
0.870x with the mesh, 1.075x with it at the edge; + Z 1511 ms, 0.864x, 1.167x.
"""
from __future__ import annotations

import statistics
import sys
import time

import numpy as np

from addon.core import reference
from addon.core.holdout import Holdout, holdout_depth
from addon.core.scene import RenderOptions
from bench.common import crop, psnr, reaching
from bench.playbot_scene import scene

RUNS = 7
SIZE = (1920, 1080)
COUNT = 500_000
SPHERE = ((0.4, -1.2, 1.12), 0.16, 50, 96)  # centre, radius, rings, segments: 9,408 triangles
PLANE = ((0.0, 0.0, 1.0), (0.0, 0.0, 0.5), (0.5, 0.45, 0.0), 24)  # centre, half axes u, v, cells a side
WINDOWS = ((1020, 520, 128, 128),   # the sphere's silhouette over the figure's body
           (790, 430, 128, 128),    # the plane cutting through the body
           (460, 640, 128, 128))    # the plane's edge over the far wall


def uv_sphere(centre, radius: float, rings: int, segments: int) -> np.ndarray:
    """(T, 3, 3) triangles of a UV sphere: 2 segments (rings - 1) of them."""
    theta = np.linspace(0.0, np.pi, rings + 1)
    phi = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    v = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1) * radius + centre
    a, b, c, d = v[:-1, :-1], v[:-1, 1:], v[1:, 1:], v[1:, :-1]
    top = np.stack([a, c, d], -2)[1:]     # the first ring's quads are triangles at the pole
    bottom = np.stack([a, b, c], -2)[:-1]
    return np.concatenate([top.reshape(-1, 3, 3), bottom.reshape(-1, 3, 3)])


def grid_plane(centre, axis_u, axis_v, cells: int) -> np.ndarray:
    """(2 cells^2, 3, 3) triangles of the rectangle centre +- axis_u +- axis_v."""
    s = np.linspace(-1.0, 1.0, cells + 1)
    u, v = np.meshgrid(s, s, indexing="ij")
    pts = np.asarray(centre) + u[..., None] * np.asarray(axis_u) + v[..., None] * np.asarray(axis_v)
    a, b, c, d = pts[:-1, :-1], pts[1:, :-1], pts[1:, 1:], pts[:-1, 1:]
    return np.concatenate([np.stack([a, b, c], -2).reshape(-1, 3, 3),
                           np.stack([a, c, d], -2).reshape(-1, 3, 3)])


EDGE = (1.6, 0.0, 0.0)  # the mesh moved this far to the right: a sliver left in view
KINDS = ("without", "with mesh", "edge")


def mesh(offset=(0.0, 0.0, 0.0)) -> Holdout:
    return Holdout(np.concatenate([uv_sphere(*SPHERE), grid_plane(*PLANE)]) + np.asarray(offset))


def timed(renderers: dict, items, cam, options: dict, runs: int) -> dict:
    """{(depth, kind): [(wall, cpu)]}, frames interleaved, the kinds' order rotating."""
    times = {key: [] for key in options}
    for run in range(runs):
        for depth in (False, True):
            order = KINDS[run % 3:] + KINDS[:run % 3]
            for kind in order:
                t, c = time.perf_counter(), time.process_time()
                renderers[depth].render(items, cam, options[(depth, kind)])
                times[(depth, kind)].append((time.perf_counter() - t, time.process_time() - c))
    return times


def errors(frame: np.ndarray, items, cam, options: RenderOptions) -> tuple[float, float]:
    """PSNR and max abs of the frame's WINDOWS against the reference with the same options."""
    got, ref = [], []
    for win in WINDOWS:
        out = reference.render(reaching(items, cam, win), cam, options, window=win)
        ref.append(out.rgba.reshape(-1, 4))
        got.append(crop(frame, win).reshape(-1, 4))
    got, ref = np.concatenate(got).astype(np.float64), np.concatenate(ref)
    return psnr(got, ref), float(np.abs(got - ref).max())


def _ms(samples, which: int) -> float:
    return 1000.0 * statistics.median(s[which] for s in samples)


def main(runs: int = RUNS):
    from addon.gl import OffscreenRenderer

    start = time.perf_counter()
    items, cam = scene(COUNT, *SIZE)
    held, edge = mesh(), mesh(EDGE)
    holdouts = {"without": None, "with mesh": held, "edge": edge}
    options = {(d, k): RenderOptions(holdout=h) for d in (False, True) for k, h in holdouts.items()}
    renderers = {False: OffscreenRenderer(depth_pass=False), True: OffscreenRenderer()}
    try:
        r = renderers[False]
        print(f"GL: {r.gl_info.get('GL_RENDERER')}; {COUNT:,} splats, SH 2, {SIZE[0]}x{SIZE[1]}; "
              f"holdout: {held.count:,} triangles (sphere {2 * SPHERE[3] * (SPHERE[2] - 1):,}, "
              f"plane {2 * PLANE[3] ** 2:,})")
        for key, opts in options.items():  # warm-up: shaders, uploads
            renderers[key[0]].render(items, cam, opts)
        surface = r.holdout_depth(held, cam)
        ref_map = holdout_depth(held, cam)
        covered = np.isfinite(ref_map)
        print(f"mesh covers {100 * covered.mean():.1f}% of the frame (edge: "
              f"{100 * np.isfinite(holdout_depth(edge, cam)).mean():.1f}%); GL surface map against "
              f"core.holdout_depth: {int((np.isfinite(surface) != covered).sum())} pixels differ in "
              f"coverage, depth max rel err "
              f"{float(np.max(np.abs(surface[covered] - ref_map[covered]) / ref_map[covered])):.1e}")
        map_ms = 1000.0 * statistics.median(_timed_call(lambda: r.holdout_depth(held, cam)) for _ in range(runs))
        times = timed(renderers, items, cam, options, runs)
        frames = {et: renderers[False].render(items, cam, RenderOptions(holdout=held, early_termination=et)).rgba
                  for et in (True, False)}
        err = {et: errors(frames[et], items, cam, RenderOptions(holdout=held, early_termination=et))
               for et in (True, False)}
    finally:
        for r in renderers.values():
            r.close()
    print(f"\nholdout, ms = median of {runs} interleaved frames (wall; CPU of all threads in brackets)")
    print(f"{'row':8s} {'without':>13s} {'with mesh':>13s} {'with/without':>14s} {'edge':>13s} "
          f"{'edge/without':>13s}")
    for depth, label in ((False, "colour"), (True, "+ Z")):
        a, b, c = (times[(depth, k)] for k in KINDS)
        cell = lambda x: f"{_ms(x, 0):.0f} ({_ms(x, 1):.0f})"
        ratio = lambda x: f"{_ms(x, 0) / _ms(a, 0):.3f} ({_ms(x, 1) / _ms(a, 1):.3f})"
        print(f"{label:8s} {cell(a):>13s} {cell(b):>13s} {ratio(b):>14s} {cell(c):>13s} {ratio(c):>13s}")
    print(f"surface depth map alone (renderer.holdout_depth, read back included): {map_ms:.1f} ms")
    print(f"held-out colour frame against the reference with the same holdout over {len(WINDOWS)} "
          f"128x128 windows: ET {err[True][0]:.1f} dB (max {err[True][1]:.1e}); "
          f"no ET {err[False][0]:.1f} dB (max {err[False][1]:.1e})")
    print(f"(whole table: {time.perf_counter() - start:.0f} s; rerun: python -m bench holdout)")


def _timed_call(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else RUNS)
