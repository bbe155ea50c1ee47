"""plyfile against Splatline's own PLY reader (issue 28, item 6): a generated 1M-splat degree-3
INRIA PLY read into a SplatSet both ways, in the same run, runs interleaved, medians.

plyfile parses the header and maps or reads the body; the records then go through the same
decode_vertices as ours, so the rows differ only in header parsing and body loading. Then a
hostile header (an unterminated comment line of --bomb-mb MB): the peak of the memory each
parser allocates (tracemalloc) while it refuses the file.

    python -m bench plyfile
    python -m bench.plyfile_bench [--count N] [--runs R]
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
import tracemalloc
import pathlib

import numpy as np

from addon.core.formats.ply import decode_vertices, read_ply, write_ply
from testing.synth import random_splats


def plyfile_read(path, mmap: bool):
    import plyfile

    rec = plyfile.PlyData.read(str(path), mmap=mmap)["vertex"].data
    return decode_vertices(path, rec, 3)


def main(argv=()) -> None:
    ap = argparse.ArgumentParser(prog="plyfile_bench")
    ap.add_argument("--count", type=int, default=1_000_000)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--small", type=int, default=20_000, help="splats of the unmapped plyfile read")
    ap.add_argument("--bomb-mb", type=int, default=100, help="size of the hostile header file")
    args = ap.parse_args(list(argv))
    try:
        import plyfile
    except ImportError:
        print("plyfile: n/a (not installed)")
        return
    readers = {
        "Splatline read_ply (plyheader + np.memmap)": lambda p: read_ply(p),
        "plyfile PlyData.read, mmap=True": lambda p: plyfile_read(p, True),
    }
    with tempfile.TemporaryDirectory() as tmp:
        path = pathlib.Path(tmp) / "big.ply"
        write_ply(path, random_splats(args.count, 3, seed=1))
        same = [fn(path) for fn in readers.values()]  # also a warm-up: the file is in the page cache
        assert all(np.array_equal(s.sh_rest, same[0].sh_rest) and np.array_equal(s.scales, same[0].scales)
                   for s in same)
        times = {name: [] for name in readers}
        for _ in range(args.runs):  # interleaved: drift on a shared machine hits every row alike
            for name, fn in readers.items():
                t = time.perf_counter()
                fn(path)
                times[name].append(time.perf_counter() - t)
        size = path.stat().st_size
        # plyfile without a memory map (a stream it cannot map) reads record by record in Python:
        # timed once, on a small file, beside ours on the same file
        small = pathlib.Path(tmp) / "small.ply"
        write_ply(small, random_splats(args.small, 3, seed=2))
        unmapped = [_seconds(lambda: read_ply(small)), _seconds(lambda: plyfile_read(small, False))]
    base = statistics.median(times[next(iter(readers))])
    print(f"{args.count:,} splats, SH degree 3, {size / 1e6:.0f} MB; median of {args.runs} interleaved runs")
    for name, ts in times.items():
        med = statistics.median(ts)
        print(f"  {name:<48} {med * 1e3:8.0f} ms  x{med / base:.2f}")
    print(f"{args.small:,} splats, one run each: Splatline {unmapped[0] * 1e3:.0f} ms, plyfile mmap=False "
          f"{unmapped[1] * 1e3:.0f} ms (x{unmapped[1] / unmapped[0]:.0f})")
    header_bomb(args.bomb_mb)


def header_bomb(mb: int) -> None:
    import plyfile

    with tempfile.TemporaryDirectory() as tmp:
        path = pathlib.Path(tmp) / "bomb.ply"
        with open(path, "wb") as f:
            f.write(b"ply\nformat binary_little_endian 1.0\ncomment ")
            f.write(b"a" * (mb << 20))
        print(f"hostile header ({mb} MB comment line, no end_header): peak allocation while refusing it")
        for name, fn in (("Splatline read_ply", read_ply), ("plyfile PlyData.read", plyfile.PlyData.read)):
            tracemalloc.start()
            try:
                fn(str(path))
            except Exception as exc:  # each refuses it in its own words
                reason = f"{type(exc).__name__}: {str(exc)[-60:]}"
            finally:
                peak = tracemalloc.get_traced_memory()[1]
                tracemalloc.stop()
            print(f"  {name:<24} {peak / 2**20:8.1f} MB  ({reason})")


def _seconds(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


if __name__ == "__main__":
    import sys

    main(sys.argv[1:])
