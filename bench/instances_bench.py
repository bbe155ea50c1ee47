"""Instances of one splat object against one object of all their splats (issue 45).

    python -m bench.instances_bench [N] [count] [degree=D] [frames=F]   (default 16 50000 1 7)
    python -m bench.instances_bench 100 100000 frames=1    (the memory row: 10M drawn)

One generated source of `count` splats drawn N times, its instances on a grid that
overlaps (so the global sort interleaves them), against the same splats merged into a
single object of N x count (what N real copies cost at best: one item, one upload). Both
go through the renderers as Splatline hands them over: evaluate.items.collect_items gives
the instances one shared SplatSet and key (RenderItem.instance tells them apart).

Rows, per renderer:
  offscreen  the GL renderer of F12, `blender -b` and the CLI (addon/gl): median ms of
             RUNS frames after a warm-up (each frame preprocesses and sorts every splat),
             the two cases' frames interleaved (a shared machine's load weighs on both);
             `uploaded` the splat bytes sent to the GPU (first frame), `frame arrays` the
             per-drawn-splat arrays the preprocess and sort keep (records, depths, keys,
             order: what sorting needs, the same for instances and copies)
  viewport   ViewportRenderer (Blender's gpu module, real bpy, background GPU): median ms
             of prepare + draw with the camera orbiting (a sort every frame); `data` the
             data textures (pos, shape, SH), `per drawn` the order and record textures
Ratios are instances / merged, in the same run. On Mesa llvmpipe (this machine) every
GPU stage runs on the 2 CPU cores.
Goal: instances cost about as much as the merged object, or less; their data bytes are
one source's.
"""
from __future__ import annotations

import statistics
import sys
import time
from dataclasses import replace

import numpy as np

from addon.core.camera import look_at, simple_camera
from addon.core.edit import merge
from addon.core.scene import RenderItem
from addon.core.splats import ARRAYS
from testing.synth import random_splats

RUNS = 7
SIZE = (256, 192)


def scene(n: int, count: int, degree: int, runs: int = RUNS):
    """(instances, merged item, cameras orbiting the grid: a warm-up and `runs` more)."""
    source = random_splats(count, degree, seed=11, spread=0.5, log_scale=(-5.0, -2.5), opacity=(0.2, 0.9))
    side = int(np.ceil(np.sqrt(n)))
    item = RenderItem(source, key=("source", 0), base_key=("source", 0), base_fields=frozenset(ARRAYS))
    instances, moved = [], []
    for k in range(n):
        world = np.eye(4)
        world[:3, 3] = (0.8 * (k % side), 0.0, 0.8 * (k // side))  # spread 0.5: neighbours overlap
        instances.append(replace(item, world=world, instance=() if k == 0 else ("grid", k)))
        moved.append(replace(source, positions=(source.positions + world[:3, 3]).astype(np.float32)))
    merged = RenderItem(merge(moved), key=("merged", 0), base_key=("merged", 0), base_fields=frozenset(ARRAYS))
    centre = np.array([0.4 * (side - 1), 0.0, 0.4 * (side - 1)])
    reach = 0.8 * side + 1.5
    cameras = []
    for k in range(runs + 1):
        a = -np.pi / 2 + 0.05 * k
        eye = centre + reach * np.array([np.cos(a), np.sin(a), 0.3])
        cameras.append(simple_camera(*SIZE, 50.0, look_at(eye, centre), near=0.05, far=10 * reach))
    return instances, merged, cameras


def _alternate(cases: dict, render, cameras) -> dict:
    """{name: median seconds}: the cases' frames interleaved camera by camera, so a load
    that comes and goes on a shared machine weighs on each alike."""
    times = {name: [] for name in cases}
    for camera in cameras[1:]:
        for name, state in cases.items():
            start = time.perf_counter()
            render(state, camera)
            times[name].append(time.perf_counter() - start)
    return {name: statistics.median(t) for name, t in times.items()}


def offscreen_rows(cases: dict, cameras) -> dict:
    from addon.gl import OffscreenRenderer
    from addon.gl.frame import FRAME_ARRAYS

    rows, states = {}, {}
    for name, items in cases.items():
        r = OffscreenRenderer(depth_pass=False)
        r.render(items, cameras[0])
        capacity = r._state.capacity if r.uses_compute else 0
        rows[name] = {"uploaded": r.stats["bytes_uploaded"],
                      "frame arrays": capacity * sum(FRAME_ARRAYS.values())}
        states[name] = (r, items)
    for name, seconds in _alternate(states, lambda st, c: st[0].render(st[1], c), cameras).items():
        rows[name] = {"ms": 1e3 * seconds, **rows[name],
                      "again": states[name][0].stats["bytes_uploaded"] - rows[name]["uploaded"]}
    for r, _ in states.values():
        r.close()
    return rows


def viewport_rows(cases: dict, cameras) -> dict:
    from addon.blender.viewport import ViewportRenderer
    from addon.blender.viewport.gpu_draw import texture_bytes
    from addon.blender.viewport.offscreen import draw_camera

    states = {name: (ViewportRenderer(), items) for name, items in cases.items()}
    for renderer, items in states.values():
        draw_camera(items, cameras[0], renderer=renderer)
    seconds = _alternate(states, lambda st, c: draw_camera(st[1], c, renderer=st[0]), cameras)
    rows = {}
    for name, (renderer, _) in states.items():
        gpu = renderer.gpu
        data = sum(texture_bytes(gpu.textures[t]) for t in ("pos", "shape", "sh") if t in gpu.textures)
        rows[name] = {"ms": 1e3 * seconds[name], "data": data, "gpu": renderer.stats.gpu_bytes,
                      "per drawn": renderer.stats.gpu_bytes - data}
        renderer.close()
    return rows


def _mb(b) -> str:
    return f"{b / 1e6:9.1f} MB"


def main(argv=()) -> None:
    args = [a for a in argv if "=" not in a]
    opts = dict(a.split("=", 1) for a in argv if "=" in a)
    n = int(args[0]) if args else 16
    count = int(args[1]) if len(args) > 1 else 50_000
    degree = int(opts.get("degree", 1))
    instances, merged, cameras = scene(n, count, degree, int(opts.get("frames", RUNS)))
    print(f"{n} instances x {count:,} splats (SH degree {degree}) = {n * count:,} drawn, {SIZE[0]}x{SIZE[1]}")
    cases = {"instances": instances, "merged": [merged]}
    rows = {("offscreen", k): v for k, v in offscreen_rows(cases, cameras).items()}
    try:
        from testing.headless import ensure_gpu

        ensure_gpu()
        rows.update({("viewport", k): v for k, v in viewport_rows(cases, cameras).items()})
    except ImportError as exc:  # no bpy in this Python
        print(f"(viewport rows skipped: {exc})")
    for (renderer, name), row in rows.items():
        cells = "  ".join(f"{k} {_mb(v)}" if k != "ms" else f"{v:8.1f} ms" for k, v in row.items())
        print(f"{renderer:10s} {name:10s} {cells}")
    for renderer in ("offscreen", "viewport"):
        if (renderer, "merged") in rows:
            a, b = rows[(renderer, "instances")], rows[(renderer, "merged")]
            print(f"{renderer:10s} instances / merged: time {a['ms'] / b['ms']:.2f}x")


if __name__ == "__main__":
    main(sys.argv[1:])
