"""KSPLAT read: a generated 1M-splat capture written as .ksplat (testing/ksplat_write.py) at
each compression level with SH degree 2, read into a SplatSet (median time, peak traced
memory), beside PlayCanvas splat-transform converting the same file to a float .ply in the
same run (its whole process: node start, read, write; "n/a" when it is not installed).

    python -m bench ksplat
    python -m bench.ksplat_bench [--count N] [--runs R] [--degree D]
"""
from __future__ import annotations

import argparse
import pathlib
import tempfile

from addon.core.formats import read
from bench.common import median_s
from bench.formats_bench import peak_bytes, run_splat_transform, splat_transform_command
from testing.ksplat_write import write_ksplat
from testing.synth import random_splats


def main(argv=None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--count", type=int, default=1_000_000)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--degree", type=int, default=2)
    args = ap.parse_args(argv or [])
    peer = splat_transform_command()
    splats = random_splats(args.count, args.degree, seed=3)
    print(f"{args.count} splats, SH degree {args.degree}, median of {args.runs} runs")
    print(f"{'level':>5} {'MB':>8} {'read s':>8} {'peak MB':>8} {'splat-transform s':>18} {'ratio':>6}")
    with tempfile.TemporaryDirectory() as tmp:
        for level in (0, 1, 2):
            path = pathlib.Path(tmp) / f"l{level}.ksplat"
            write_ksplat(path, splats, level=level, degree=args.degree)
            ours = median_s(lambda: read(path), args.runs, warm_up=True)
            peak = peak_bytes(lambda: read(path)) / 2**20
            theirs = (median_s(lambda: run_splat_transform(peer, path, pathlib.Path(tmp) / "peer.ply"), args.runs)
                      if peer else None)
            print(f"{level:>5} {path.stat().st_size / 2**20:>8.1f} {ours:>8.3f} {peak:>8.0f} "
                  + (f"{theirs:>18.3f} {theirs / ours:>6.1f}" if theirs else f"{'n/a (not installed)':>18}"),
                  flush=True)


if __name__ == "__main__":
    import sys
    main(sys.argv[1:])
