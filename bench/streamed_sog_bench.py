"""Streamed SOG read speed and memory: a generated capture (1M splats at its finest level, a
quarter at the next; SH degree 3 by default) written as a streamed SOG by splat-transform's
own LOD writer, then its finest level read by Splatline and by splat-transform, each in a
process of its own so its peak resident memory is its own. Medians of --runs:

  splatline read      formats.read(lod-meta.json) inside the process (the decode alone)
  splatline process   the whole `python -c` process: start-up, imports, read
  splatline convert   `python -m addon convert lod-meta.json out.ply`
  peer read           `splat-transform -L 0 lod-meta.json null` (read, no output)
  peer convert        `splat-transform -L 0 lod-meta.json out.ply`

    python -m bench.streamed_sog_bench [--count N] [--degree D] [--runs R]

Needs splat-transform (PATH or $SPLATLINE_SPLAT_TRANSFORM; `make peers`) to make the file.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

from bench.formats_bench import splat_transform_command
from testing.paths import REPO
from testing.streamed_sog_files import levels_of, make_streamed_sog
from testing.synth import random_splats

READ = ("import json, sys, time\nfrom addon.core.formats import read\n"
        "t = time.perf_counter(); s = read(sys.argv[1]); t = time.perf_counter() - t\n"
        "print(json.dumps({'read_s': t, 'count': s.count}))")


def _run(cmd) -> tuple[float, float, str]:
    """(wall s, peak resident MiB, stdout) of one child process, its rusage from wait4."""
    t = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out, err = proc.stdout.read(), proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        raise RuntimeError(f"{' '.join(map(str, cmd))} failed: {err[-2000:]}")
    return wall, usage.ru_maxrss / 1024, out


def _medians(cmd, runs: int, parse=None) -> dict:
    rows = [_run(cmd) for _ in range(runs)]
    out = {"wall_s": statistics.median(r[0] for r in rows), "peak_mib": statistics.median(r[1] for r in rows)}
    if parse:
        out["read_s"] = statistics.median(parse(r[2]) for r in rows)
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=1_000_000, help="splats at the finest level (default 1M)")
    parser.add_argument("--degree", type=int, default=3, help="SH degree (default 3)")
    parser.add_argument("--runs", type=int, default=5, help="runs per figure (default 5)")
    args = parser.parse_args(argv)
    peer = splat_transform_command()
    if peer is None:
        print("streamed SOG bench: splat-transform is not installed (set $SPLATLINE_SPLAT_TRANSFORM)")
        return 1
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        levels = levels_of(random_splats(args.count, args.degree), (1, 4))
        path = make_streamed_sog(peer, tmp, levels, chunk_k=512)
        made = time.perf_counter() - t
        chunks = len(json.loads(path.read_text())["filenames"])
        for name in ("l0.ply", "l1.ply"):
            os.remove(os.path.join(tmp, name))
        print(f"streamed SOG: {args.count:,} + {levels[1].count:,} splats, SH degree {args.degree}, "
              f"{chunks} chunks, made by splat-transform in {made:.0f} s; medians of {args.runs} runs")
        out = os.path.join(tmp, "out.ply")
        rows = {
            "splatline read (in process)": _medians([sys.executable, "-c", READ, path], args.runs,
                                                    lambda text: json.loads(text)["read_s"]),
            "splatline convert -> .ply": _medians([sys.executable, "-m", "addon", "convert", path, out], args.runs),
            "splat-transform read (-> null)": _medians([*peer, "-q", "-L", "0", path, "null"], args.runs),
            "splat-transform convert -> .ply": _medians([*peer, "-q", "-w", "-L", "0", path, out], args.runs),
        }
    print(f"{'':<34} {'read s':>7} {'process s':>9} {'peak MiB':>9}")
    for name, row in rows.items():
        read_s = f"{row['read_s']:.2f}" if "read_s" in row else "-"
        print(f"{name:<34} {read_s:>7} {row['wall_s']:>9.2f} {row['peak_mib']:>9.0f}")
    ours, theirs = rows["splatline read (in process)"], rows["splat-transform read (-> null)"]
    conv, peer_conv = rows["splatline convert -> .ply"], rows["splat-transform convert -> .ply"]
    print(f"ratio splatline/splat-transform: read process {ours['wall_s'] / theirs['wall_s']:.2f}x time, "
          f"{ours['peak_mib'] / theirs['peak_mib']:.2f}x peak; convert {conv['wall_s'] / peer_conv['wall_s']:.2f}x "
          f"time, {conv['peak_mib'] / peer_conv['peak_mib']:.2f}x peak")
    return 0


if __name__ == "__main__":
    sys.exit(main())
