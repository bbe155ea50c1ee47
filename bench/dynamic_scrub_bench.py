"""Scrubbing a dynamic capture in the viewport, beside a static one, in real bpy.

A generated Spacetime-lite capture of N splats imported as Splatline imports it (one object,
its time model in the PointCloud) and a static capture of N splats (its rest pose), alone
(nothing changes: the caches hold) and with an Explode effect (the static scrub that moves
every splat each frame, as the dynamic capture does), each scrubbed over frames 2..13 with a still view: per frame, the evaluation (collect_items: the
source's frame at its capture time, sorted-out splats below 1/255 left out), then the
viewport's prepare (packing, upload, sort inline). Medians in ms, and the ratio of the
dynamic frame to the static one in the same run. Also numpy's argsort of N float32 depths
(the evaluation's budget, issue 40) and Blender's bytes per dynamic splat.

Usage: python -m bench.dynamic_scrub_bench [N]   (default 1,000,000)
"""
from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench.viewport_bench import HEIGHT, WIDTH, _argsort_ms, _projection, _view  # noqa: E402

FRAMES = range(2, 14)


def _scrub(bpy, obj, renderer, proj) -> tuple[float, float, float]:
    """(evaluation, prepare, total) ms medians over FRAMES for the one object."""
    from addon.blender.evaluate.items import collect_items
    from addon.blender.viewport import DrawSettings

    settings = DrawSettings(sync_sort=True)
    evals, prepares = [], []
    view = _view(0)
    for frame in (1, *FRAMES):  # frame 1 warms up (first upload, shader, caches)
        bpy.context.scene.frame_set(frame)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        start = time.perf_counter()
        items = [i for i in collect_items(depsgraph) if i.key[0] == obj.name_full]
        mid = time.perf_counter()
        renderer.prepare(items, view, proj, (WIDTH, HEIGHT), settings)
        end = time.perf_counter()
        if frame != 1:
            evals.append(mid - start)
            prepares.append(end - mid)
    e, p = (1e3 * statistics.median(x) for x in (evals, prepares))
    return e, p, e + p


def main(argv=()) -> None:
    import bpy
    import gpu

    import addon
    from addon.blender.data.dynamic_files import dynamic_blender_bytes, import_dynamic
    from addon.blender.data.files import import_file
    from addon.blender.viewport import ViewportRenderer
    from addon.core.dynamic import read_dynamic, write_dynamic
    from addon.core.formats import write
    from testing.dynamic_scenes import spacetime_capture
    from testing.headless import ensure_gpu

    n = int(argv[0]) if argv else 1_000_000
    addon.register()
    ensure_gpu()
    proj = _projection()
    with tempfile.TemporaryDirectory() as folder:
        capture = spacetime_capture(n, seed=3)
        write_dynamic(Path(folder) / "dynamic.ply", capture)
        write(Path(folder) / "static.ply", capture.rest(), "ply")
        capture = read_dynamic(Path(folder) / "dynamic.ply")
        rows = {}
        for name in ("static", "exploding", "dynamic"):
            bpy.ops.wm.read_factory_settings(use_empty=True)
            path = str(Path(folder) / f"{'dynamic' if name == 'dynamic' else 'static'}.ply")
            obj = import_dynamic(bpy.context, path) if name == "dynamic" else import_file(bpy.context, path)
            if name == "exploding":
                _explode(bpy, obj)
            renderer = ViewportRenderer(worker=False)
            off = gpu.types.GPUOffScreen(WIDTH, HEIGHT, format="RGBA16F")
            with off.bind():
                rows[name] = _scrub(bpy, obj, renderer, proj)
            off.free()
            renderer.close()
    argsort, _ = _argsort_ms(n)
    at = statistics.median(_timed(capture.at, t) for t in np.linspace(0.05, 0.95, 7))
    print(f"dynamic scrub, {n:,} splats, SH degree 0, {WIDTH}x{HEIGHT}, still view, inline sort; "
          f"ms per frame, medians of {len(FRAMES)} frames")
    print(f"{'capture':>9} {'evaluate':>9} {'prepare':>8} {'total':>8} {'vs exploding':>12}")
    for name, (e, p, total) in rows.items():
        print(f"{name:>9} {e:>9.1f} {p:>8.1f} {total:>8.1f} {total / rows['exploding'][2]:>12.2f}")
    print(f"capture.at(t) alone {at:.1f} ms against argsort of {n:,} float32 {argsort:.1f} ms: "
          f"{at / argsort:.2f}x")
    print(f"Blender's bytes per dynamic splat: {dynamic_blender_bytes(capture) / n:.0f} "
          f"(the rest splats' attributes and the time model's)")


def _explode(bpy, obj) -> None:
    bpy.context.view_layer.objects.active = obj
    with bpy.context.temp_override(object=obj):
        bpy.ops.splatline.effect_add(type="EXPLODE")
    obj.splatline.effects[-1].start_frame = 1.0


def _timed(fn, t) -> float:
    start = time.perf_counter()
    fn(t)
    return 1e3 * (time.perf_counter() - start)


if __name__ == "__main__":
    main(sys.argv[1:])
