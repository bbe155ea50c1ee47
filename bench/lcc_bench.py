"""XGRIDS LCC reading: a generated scene of N splats at LOD 0 (default 1M, SH degree 3, a
coarser LOD 1 of N/4 beside it, 64 quadtree units; testing/lcc_files.py writes it) read by
Splatline in-process (median wall seconds and the Python peak, tracemalloc: numpy's arrays
included), then as whole commands converting it to a float .ply: `python -m addon convert` and
PlayCanvas splat-transform (its default: LOD 0), alternating runs so both see the same load,
and Splatline's convert of the same splats from a float .ply (the command without the LCC read).
splat-transform's rows say "n/a" when it is not installed ($SPLATLINE_SPLAT_TRANSFORM or PATH).

    python -m bench.lcc_bench [--count N] [--runs R] [--portable]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import pathlib

from addon.core.formats import read
from bench.common import median_s
from bench.formats_bench import _process_seconds, peak_bytes, splat_transform_command
from testing.lcc_files import write_lcc
from testing.synth import random_splats


def main(argv=()) -> None:
    ap = argparse.ArgumentParser(prog="bench.lcc_bench")
    ap.add_argument("--count", type=int, default=1_000_000, help="splats at LOD 0 (default 1000000)")
    ap.add_argument("--runs", type=int, default=5, help="timed runs of each row (default 5)")
    ap.add_argument("--portable", action="store_true", help="no SH (fileType Portable; default: SH degree 3)")
    args = ap.parse_args(list(argv))
    degree = 0 if args.portable else 3
    peer = splat_transform_command()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        lods = [random_splats(args.count, degree, seed=1, dc=0.5), random_splats(args.count // 4, degree, seed=2, dc=0.5)]
        path = write_lcc(tmp / "scene", lods, sh=degree > 0, units=64)
        del lods
        size = sum(f.stat().st_size for f in (tmp / "scene").iterdir())
        read_s = median_s(lambda: read(path), args.runs, warm_up=True)
        peak = peak_bytes(lambda: read(path))
        ours, theirs, from_ply = [], [], []
        for _ in range(args.runs):
            ours.append(_process_seconds([sys.executable, "-m", "addon", "convert", path, tmp / "ours.ply"], None))
            if peer is not None:
                theirs.append(_process_seconds([*peer, "-w", "-q", path, tmp / "peer.ply"], None))
            # the same splats from a float .ply: what the command costs without the LCC read
            from_ply.append(_process_seconds([sys.executable, "-m", "addon", "convert", tmp / "ours.ply",
                                              tmp / "again.ply"], None))
    print(f"LCC scene: {args.count:,} splats at LOD 0 (+ {args.count // 4:,} at LOD 1), SH degree {degree}, "
          f"{size / 1e6:.0f} MB in all; medians of {args.runs} runs")
    print(f"{'what':<52} {'seconds':>8} {'peak MB':>8}")
    print(f"{'splatline read() of LOD 0 (in-process)':<52} {read_s:8.3f} {peak / 1e6:8.0f}")
    ours_s = statistics.median(ours)
    print(f"{'python -m addon convert scene/meta.lcc out.ply':<52} {ours_s:8.3f}")
    print(f"{'python -m addon convert out.ply again.ply (baseline)':<52} {statistics.median(from_ply):8.3f}")
    if peer is None:
        print(f"{'splat-transform scene/meta.lcc out.ply':<52} {'n/a (not installed)':>8}")
        return
    theirs_s = statistics.median(theirs)
    print(f"{'splat-transform scene/meta.lcc out.ply':<52} {theirs_s:8.3f}")
    print(f"ratios: convert / splat-transform {ours_s / theirs_s:.2f}; read / splat-transform {read_s / theirs_s:.2f}")


if __name__ == "__main__":
    main(sys.argv[1:])
