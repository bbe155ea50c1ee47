"""Import speed and memory: Splatline's import of a 1M-splat degree-3 INRIA PLY into a
PointCloud object against Blender's own C++ `bpy.ops.wm.ply_import` of the same file.

    python -m bench import            (or: make bench)

Every run is one import in a fresh Python process (bpy imported and an empty scene set up
before the clock starts), as a user's first import would be; the variants alternate, so
load from other processes on the machine hits both alike. Peak memory is that process's
RSS high-water mark (/proc/self/status VmHWM, which counts the C allocations tracemalloc
cannot see) minus its RSS just before the import. The file is generated once in a
temporary folder (the page cache then holds it for both variants) and deleted.
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


def _importer(variant: str, bpy, stages: list):
    if variant == "splatline":
        from addon.blender.data.files import import_file_with_report

        # the progress callback marks the end of reading (and of building)
        def run(path):
            import_file_with_report(bpy.context, path, progress=lambda _: stages.append(time.perf_counter()))
        return run
    return lambda path: bpy.ops.wm.ply_import(filepath=path)


def worker(variant: str, path: str) -> dict:
    """Runs in the child process: one timed import."""
    sys.path.insert(0, ROOT)
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    stages = []
    run = _importer(variant, bpy, stages)
    rss_before = _status_kb("VmRSS")
    t0 = time.perf_counter()
    run(path)
    seconds = time.perf_counter() - t0
    peak = _status_kb("VmHWM") - rss_before
    read = stages[0] - t0 if stages else float("nan")
    return {"variant": variant, "seconds": seconds, "read": read, "peak_mb": peak / 1024,
            "points": _count(bpy)}


def _count(bpy) -> int:
    obj = bpy.data.objects[-1]
    return len(obj.data.points) if obj.type == "POINTCLOUD" else len(obj.data.vertices)


def _child(variant: str, path: str) -> dict:
    cmd = [sys.executable, "-m", "bench.import_bench", "--worker", variant, path]
    out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=True).stdout
    # Blender's own C prints share stdout and may be flushed after ours: find our line
    line = next(line for line in out.splitlines() if line.startswith(MARKER))
    return json.loads(line[len(MARKER):])


def make_file(folder: str) -> str:
    sys.path.insert(0, ROOT)
    from addon.core.formats import write
    from testing.synth import random_splats

    path = os.path.join(folder, "bench_1m_deg3.ply")
    write(path, random_splats(COUNT, DEGREE, seed=0))
    return path


def main(runs: int = RUNS) -> dict:
    with tempfile.TemporaryDirectory(prefix="splatline_bench_") as folder:
        path = make_file(folder)
        size_mb = os.path.getsize(path) / 1e6
        runs_of = {v: [] for v in VARIANTS}
        for _ in range(runs):
            for variant in VARIANTS:
                runs_of[variant].append(_child(variant, path))
    results = {}
    for variant, rs in runs_of.items():
        times = [r["seconds"] for r in rs]
        results[variant] = {"median": statistics.median(times), "min": min(times), "runs": len(rs),
                            "read": statistics.median(r["read"] for r in rs),
                            "peak_mb": statistics.median(r["peak_mb"] for r in rs),
                            "points": rs[0]["points"]}
    _print(results, size_mb)
    return results


def _print(results: dict, size_mb: float) -> None:
    print(f"INRIA PLY, {COUNT:,} splats, SH degree {DEGREE}, {size_mb:.0f} MB; medians of "
          f"{results['splatline']['runs']} runs, each one import in a fresh process, variants alternating")
    print(f"{'variant':40s} {'median s':>9s} {'min s':>7s} {'read s':>7s} {'points':>9s} {'peak RSS +MB':>13s}")
    for variant in VARIANTS:
        r = results[variant]
        read = "-" if r["read"] != r["read"] else f"{r['read']:.3f}"  # NaN: no separate read stage
        print(f"{LABELS[variant]:40s} {r['median']:9.3f} {r['min']:7.3f} {read:>7s} {r['points']:9d} "
              f"{r['peak_mb']:13.0f}")
    ratio = results["splatline"]["median"] / results["blender"]["median"]
    print(f"ratio Splatline / Blender (median): {ratio:.2f}  (goal <= 1.00: {'met' if ratio <= 1.0 else 'NOT met'})")


if __name__ == "__main__":
    if len(sys.argv) >= 4 and sys.argv[1] == "--worker":
        print(MARKER + json.dumps(worker(sys.argv[2], sys.argv[3])), flush=True)
    else:
        main()
