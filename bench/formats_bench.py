"""Reader speed: a generated 1M-splat degree-3 INRIA PLY (about 248 MB) read into a SplatSet,
beside Blender's C++ wm.ply_import of the same file (when bpy is importable) and a plain
np.fromfile of its bytes, all in the same run; plus every testdata capture.

Then every writer on guitar and test64: file size and median write time.

    python -m bench.formats_bench [--count N] [--runs R] [--writers-only]
"""
from __future__ import annotations

import argparse
import os
import pathlib
import shutil
import statistics
import subprocess
import tempfile
import time
import tracemalloc

import numpy as np

from addon.core.formats import read, write
from addon.core.formats.ply import write_ply
from addon.core.formats.synth import random_splats

TESTDATA = pathlib.Path(__file__).resolve().parents[1].parent / "shared" / "testdata"
PEER_ENV = "SPLATLINE_SPLAT_TRANSFORM"


def splat_transform_command() -> list | None:
    """The PlayCanvas splat-transform command line to run, or None when it is not installed:
    $SPLATLINE_SPLAT_TRANSFORM (a path to its executable), else `splat-transform` on PATH.
    It is an outside tool (npm @playcanvas/splat-transform) used only to cross-check and
    compare against; Splatline never needs it."""
    exe = os.environ.get(PEER_ENV) or shutil.which("splat-transform")
    return [exe] if exe and os.access(exe, os.X_OK) else None


def run_splat_transform(cmd: list, *args) -> None:
    """Run splat-transform quietly, overwriting outputs; RuntimeError with its stderr on failure."""
    proc = subprocess.run([*cmd, "-w", "-q", *map(str, args)], capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(f"splat-transform {' '.join(map(str, args))} failed: {proc.stderr[-2000:]}")


def timed(fn, runs: int):
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def peak_bytes(fn) -> int:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


class _quiet_stdout:
    """Blender's importer prints a line per call from C; keep the table readable."""

    def __enter__(self):
        self.saved = os.dup(1)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)
        os.close(devnull)

    def __exit__(self, *exc):
        os.dup2(self.saved, 1)
        os.close(self.saved)


def blender_ply_import(path):
    """A callable running Blender's own importer, or None without bpy."""
    try:
        import bpy
    except ImportError:
        return None
    bpy.ops.wm.read_factory_settings(use_empty=True)

    def run():
        with _quiet_stdout():
            bpy.ops.wm.ply_import(filepath=str(path))
        for obj in list(bpy.data.objects):
            bpy.data.objects.remove(obj)
        for mesh in list(bpy.data.meshes):
            bpy.data.meshes.remove(mesh)
    return run


def main(argv=None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--count", type=int, default=1_000_000)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--writers-only", action="store_true", help="only the writer table")
    args = ap.parse_args(argv)
    if args.writers_only:
        return writer_rows(args.runs)
    with tempfile.TemporaryDirectory() as tmp:
        path = pathlib.Path(tmp) / "bench.ply"
        write_ply(path, random_splats(args.count, 3))
        size = os.path.getsize(path)
        rows = [("np.fromfile of the bytes (floor)", timed(lambda: np.fromfile(path, np.uint8), args.runs), None)]
        ours = timed(lambda: read(path), args.runs)
        rows.append(("splatline read() (decode + validate)", ours, peak_bytes(lambda: read(path))))
        blender = blender_ply_import(path)
        if blender is not None:
            blender()  # warm-up: first operator call initialises Blender's importer
            rows.append(("blender wm.ply_import (C++)", timed(blender, args.runs), None))
        print(f"{args.count:,} splats, SH degree 3, {size / 1e6:.0f} MB; median of {args.runs} runs")
        print(f"{'reader':<40} {'seconds':>8} {'peak MB':>8}")
        for name, sec, peak in rows:
            print(f"{name:<40} {sec:8.3f} {'' if peak is None else f'{peak / 1e6:8.0f}'}")
        if blender is not None:
            print(f"ratio splatline / blender: {ours / rows[-1][1]:.2f} (goal <= 1.0)")
    print(f"\n{'testdata file':<28} {'splats':>8} {'ms':>8}")
    for f in sorted(TESTDATA.glob("*.*")):
        if f.suffix in (".ply", ".splat", ".spz"):
            ms = timed(lambda: read(f), args.runs) * 1e3
            print(f"{f.name:<28} {read(f).count:>8} {ms:8.1f}")

    writer_rows(args.runs)


# output name for each writer (a meta.json names an unbundled SOG, written into its own folder)
WRITERS = (("ply", "o.ply", {}), ("compressed_ply", "o.compressed.ply", {}), ("splat", "o.splat", {}),
           ("spz v4", "o.spz", {}), ("spz v3", "o3.spz", {"version": 3}), ("sog", "o.sog", {}),
           ("sog unbundled", "un/meta.json", {}), ("glb", "o.glb", {}))


def _size(path: pathlib.Path) -> int:
    """A file's size; an unbundled SOG's is its whole folder."""
    if path.name == "meta.json":
        return sum(f.stat().st_size for f in path.parent.iterdir())
    return path.stat().st_size


def writer_rows(runs: int) -> None:
    print(f"\n{'capture':<8} {'writer':<15} {'bytes':>11} {'B/splat':>8} {'ms':>9}")
    for capture in ("guitar", "test64"):
        splats = read(TESTDATA / f"{capture}.ply")
        with tempfile.TemporaryDirectory() as tmp:
            (pathlib.Path(tmp) / "un").mkdir()
            for label, name, options in WRITERS:
                out = pathlib.Path(tmp) / name
                ms = timed(lambda: write(out, splats, **options), runs) * 1e3
                size = _size(out)
                print(f"{capture:<8} {label:<15} {size:>11,} {size / splats.count:>8.2f} {ms:>9.1f}")


if __name__ == "__main__":
    main()
