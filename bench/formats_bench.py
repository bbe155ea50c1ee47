"""Reader speed: a generated 1M-splat degree-3 INRIA PLY (about 248 MB) read into a SplatSet,
beside Blender's C++ wm.ply_import of the same file (when bpy is importable) and a plain
np.fromfile of its bytes, all in the same run; plus every testdata capture.

Then every writer on guitar and a generated degree-3 capture: file size and write time,
beside PlayCanvas splat-transform's on the same .ply when it is installed (PATH, or
$SPLATLINE_SPLAT_TRANSFORM; rows say "n/a (not installed)" otherwise).

    python -m bench formats
    python -m bench.formats_bench [--count N] [--runs R] [--writers-only] [--writer-count N]
"""
from __future__ import annotations

import argparse
import os
import pathlib
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import tracemalloc

import numpy as np

from addon.core.formats import read, write
from addon.core.formats.ply import write_ply
from testing.synth import random_splats
from bench.common import median_s
from testing.paths import SHARED_TESTDATA

TESTDATA = SHARED_TESTDATA
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


def main(argv=()) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--count", type=int, default=1_000_000)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--writer-runs", type=int, default=3)
    ap.add_argument("--writer-count", type=int, default=300_000, help="splats in the generated writer capture")
    ap.add_argument("--peer-timeout", type=float, default=180.0, help="seconds before a splat-transform run is stopped")
    ap.add_argument("--writers-only", action="store_true", help="only the writer table")
    args = ap.parse_args(list(argv))
    if args.writers_only:
        return writer_rows(args.writer_runs, args.writer_count, args.peer_timeout)
    with tempfile.TemporaryDirectory() as tmp:
        path = pathlib.Path(tmp) / "bench.ply"
        write_ply(path, random_splats(args.count, 3))
        size = os.path.getsize(path)
        rows = [("np.fromfile of the bytes (floor)", median_s(lambda: np.fromfile(path, np.uint8), args.runs), None)]
        ours = median_s(lambda: read(path), args.runs)
        rows.append(("splatline read() (decode + validate)", ours, peak_bytes(lambda: read(path))))
        blender = blender_ply_import(path)
        if blender is not None:
            blender()  # warm-up: first operator call initialises Blender's importer
            rows.append(("blender wm.ply_import (C++)", median_s(blender, args.runs), None))
        print(f"{args.count:,} splats, SH degree 3, {size / 1e6:.0f} MB; median of {args.runs} runs")
        print(f"{'reader':<40} {'seconds':>8} {'peak MB':>8}")
        for name, sec, peak in rows:
            print(f"{name:<40} {sec:8.3f} {'' if peak is None else f'{peak / 1e6:8.0f}'}")
        if blender is not None:
            print(f"ratio splatline / blender: {ours / rows[-1][1]:.2f} (goal <= 1.0)")
    print(f"\n{'testdata file':<28} {'splats':>8} {'ms':>8}")
    for f in sorted(TESTDATA.glob("*.*")):
        if f.suffix in (".ply", ".splat", ".spz"):
            ms = median_s(lambda: read(f), args.runs) * 1e3
            print(f"{f.name:<28} {read(f).count:>8} {ms:8.1f}")

    writer_rows(args.writer_runs, args.writer_count, args.peer_timeout)


# label, output name (a meta.json: an unbundled SOG in its own folder), write() options, the
# same for `python -m addon convert`, and splat-transform's flags (None: it has no such writer;
# 3.7.0 writes no .splat). -g cpu: no GPU here; splat-transform's SOG k-means uses one when it can.
WRITERS = (("ply", "o.ply", {}, [], []), ("compressed_ply", "o.compressed.ply", {}, [], []),
           ("splat", "o.splat", {}, [], None), ("spz v4", "o.spz", {}, [], []),
           ("spz v3", "o3.spz", {"version": 3}, ["--spz-version", "3"], ["--spz-version", "3"]),
           ("sog", "o.sog", {}, [], ["-g", "cpu"]), ("sog unbundled", "un/meta.json", {}, [], ["-g", "cpu"]),
           ("glb", "o.glb", {}, [], []))
ROOT = pathlib.Path(__file__).resolve().parents[1]


def _size(path: pathlib.Path) -> int:
    """A file's size; an unbundled SOG's is its whole folder."""
    if path.name == "meta.json":
        return sum(f.stat().st_size for f in path.parent.iterdir())
    return path.stat().st_size


def _process_seconds(args, timeout) -> float | None:
    """Wall seconds of one process run to completion; None when it ran past timeout."""
    t = time.perf_counter()
    try:
        proc = subprocess.run(args, capture_output=True, text=True, timeout=timeout, cwd=ROOT)
    except subprocess.TimeoutExpired:
        return None
    if proc.returncode:
        raise RuntimeError(f"{' '.join(map(str, args))} failed: {proc.stderr[-2000:]}")
    return time.perf_counter() - t


def _captures(tmp: pathlib.Path, count: int):
    """(name, float .ply path both tools start from, the splats in it)."""
    yield "guitar", TESTDATA / "guitar.ply", read(TESTDATA / "guitar.ply")
    path = tmp / "synth.ply"
    write_ply(path, random_splats(count, 3))
    yield f"synth {count // 1000}k", path, read(path)


def _cli_pair(src, out, peer_out, cli_flags, peer_flags, runs, timeout, peer):
    """Median wall seconds of `python -m addon convert` and of splat-transform (None: absent,
    "timeout": ran past timeout), alternating runs so both see the same machine load."""
    ours, theirs = [], []
    for _ in range(runs):
        ours.append(_process_seconds([sys.executable, "-m", "addon", "convert", src, out, *cli_flags], None))
        if peer is not None and peer_flags is not None and theirs is not None:
            sec = _process_seconds([*peer, "-w", "-q", *peer_flags, src, peer_out], timeout)
            theirs = None if sec is None else theirs + [sec]
    if peer is None or peer_flags is None:
        return statistics.median(ours), None
    return statistics.median(ours), "timeout" if theirs is None else statistics.median(theirs)


def _peer_cells(peer, peer_flags, sec, size, our_sec, our_size, timeout) -> str:
    if peer is None:
        return f"{'n/a (not installed)':>42}"
    if peer_flags is None:
        return f"{'n/a (splat-transform has no such writer)':>42}"
    if sec == "timeout":
        return f"{'':>11} {f'> {timeout:.0f} s (stopped)':>18} {'':>6} {'':>5}"
    return f"{size:>11,} {sec:>8.2f} {our_size / size:>6.3f} {our_sec / sec:>5.2f}"


def writer_rows(runs: int, count: int = 300_000, timeout: float = 180.0) -> None:
    """Every writer: Splatline's in-process write time and size, then the same conversion from
    the capture's .ply as a whole command, `python -m addon convert` beside splat-transform's
    (process start + read + write for both). Ratios are Splatline / splat-transform."""
    peer = splat_transform_command()
    print(f"\nwriters, medians of {runs}; cli = the whole command from the .ply; ratios Splatline / "
          f"splat-transform{'' if peer else ' (splat-transform not installed: set $' + PEER_ENV + ')'}")
    print(f"{'capture':<12} {'writer':<15} {'bytes':>11} {'B/splat':>7} {'write ms':>9} {'cli s':>7} | "
          f"{'peer bytes':>11} {'peer cli s':>8} {'size x':>6} {'cli x':>5}")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        for folder in ("un", "cli_un", "peer_un"):
            (tmp / folder).mkdir()
        for capture, src, splats in _captures(tmp, count):
            for label, name, options, cli_flags, peer_flags in WRITERS:
                out = tmp / name
                ms = median_s(lambda: write(out, splats, **options), runs) * 1e3
                size = _size(out)
                cli_out, peer_out = (tmp / f"cli_{name}", tmp / f"peer_{name}")
                cli, peer_sec = _cli_pair(src, cli_out, peer_out, cli_flags, peer_flags, runs, timeout, peer)
                peer_size = _size(peer_out) if isinstance(peer_sec, float) else None
                cells = _peer_cells(peer, peer_flags, peer_sec, peer_size, cli, size, timeout)
                print(f"{capture:<12} {label:<15} {size:>11,} {size / splats.count:>7.2f} {ms:>9.1f} "
                      f"{cli:>7.2f} | {cells}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
