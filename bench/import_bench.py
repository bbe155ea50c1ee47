"""Import speed and memory: Splatline's import of a 1M-splat degree-3 INRIA PLY into a
PointCloud object against Blender's own C++ `bpy.ops.wm.ply_import` of the same file.

    python -m bench import            (or: make bench)

Each variant runs in its own fresh Python process: one for the timings (a warm-up, then
RUNS timed imports, the created data removed after each), and one more for the memory (a
single import; peak RSS from /proc/self/status VmHWM, which counts C allocations that
tracemalloc cannot see). The file is generated once in a temporary folder and deleted.
"""
from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
COUNT = 1_000_000
DEGREE = 3
RUNS = 5
MARKER = "IMPORT_BENCH "
VARIANTS = ("splatline", "blender")
LABELS = {"splatline": "Splatline import_file -> PointCloud",
          "blender": "Blender wm.ply_import (C++) -> Mesh"}


def _status_kb(key: str) -> int:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    return 0


def _clear(bpy) -> None:
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    for coll in (bpy.data.meshes, bpy.data.pointclouds):
        for block in list(coll):
            coll.remove(block)


def _importer(variant: str, bpy):
    if variant == "splatline":
        from addon.blender.import_splats import import_file

        return lambda path: import_file(bpy.context, path)
    return lambda path: bpy.ops.wm.ply_import(filepath=path)


def worker(variant: str, path: str, runs: int) -> dict:
    """Runs in the child process; prints one JSON line."""
    sys.path.insert(0, ROOT)
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    run = _importer(variant, bpy)
    rss_before = _status_kb("VmRSS")
    times = []
    for i in range(runs + (1 if runs > 1 else 0)):
        t0 = time.perf_counter()
        run(path)
        times.append(time.perf_counter() - t0)
        if i == 0:
            peak = _status_kb("VmHWM") - rss_before
            points = _count(bpy)
        _clear(bpy)
    timed = times[1:] if runs > 1 else times
    return {"variant": variant, "times": timed, "peak_mb": peak / 1024, "points": points}


def _count(bpy) -> int:
    obj = bpy.data.objects[-1]
    return len(obj.data.points) if obj.type == "POINTCLOUD" else len(obj.data.vertices)


def _child(variant: str, path: str, runs: int) -> dict:
    cmd = [sys.executable, "-m", "bench.import_bench", "--worker", variant, path, str(runs)]
    out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=True).stdout
    # Blender's own C prints share stdout and may be flushed after ours: find our line
    line = next(line for line in out.splitlines() if line.startswith(MARKER))
    return json.loads(line[len(MARKER):])


def make_file(folder: str) -> str:
    sys.path.insert(0, ROOT)
    from addon.core.formats import write
    from addon.core.formats.synth import random_splats

    path = os.path.join(folder, "bench_1m_deg3.ply")
    write(path, random_splats(COUNT, DEGREE, seed=0))
    return path


def main(runs: int = RUNS) -> dict:
    with tempfile.TemporaryDirectory(prefix="splatline_bench_") as folder:
        path = make_file(folder)
        size_mb = os.path.getsize(path) / 1e6
        results = {}
        for variant in VARIANTS:
            timing = _child(variant, path, runs)
            memory = _child(variant, path, 1)
            results[variant] = {"median": statistics.median(timing["times"]), "min": min(timing["times"]),
                                "runs": len(timing["times"]), "peak_mb": memory["peak_mb"],
                                "points": timing["points"]}
    _print(results, size_mb)
    return results


def _print(results: dict, size_mb: float) -> None:
    print(f"INRIA PLY, {COUNT:,} splats, SH degree {DEGREE}, {size_mb:.0f} MB; medians of "
          f"{results['splatline']['runs']} runs after a warm-up, each variant in a fresh process")
    print(f"{'variant':40s} {'median s':>9s} {'min s':>7s} {'points':>9s} {'peak RSS +MB':>13s}")
    for variant in VARIANTS:
        r = results[variant]
        print(f"{LABELS[variant]:40s} {r['median']:9.3f} {r['min']:7.3f} {r['points']:9d} {r['peak_mb']:13.0f}")
    ratio = results["splatline"]["median"] / results["blender"]["median"]
    print(f"ratio Splatline / Blender (median): {ratio:.2f}  (goal <= 1.00: {'met' if ratio <= 1.0 else 'NOT met'})")


if __name__ == "__main__":
    if len(sys.argv) >= 5 and sys.argv[1] == "--worker":
        print(MARKER + json.dumps(worker(sys.argv[2], sys.argv[3], int(sys.argv[4]))), flush=True)
    else:
        main()
