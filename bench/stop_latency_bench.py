"""How long a render takes to stop after SIGTERM, at any moment of a large job (issue 41).

    python -m bench.stop_latency_bench [--splats 10000000] [--delays 5,15,30,45]

A generated INRIA PLY (degree 0) is rendered at 1920x1080, 3 frames, by `python -m addon render`
in a child process; SIGTERM is sent DELAY seconds after it started (reading, building the
scene, mid-frame: wherever it is), and the seconds from the signal to the process's exit are
printed with its exit status, then their median. A job that ends before its delay is said so.
"""
from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time

from testing.paths import REPO


def stop_after(capture: str, out: str, delay: float) -> tuple[float | None, int, str]:
    child = subprocess.Popen([sys.executable, "-m", "addon", "render", capture, "--out", out,
                              "--frames", "1-3", "--resolution", "1920x1080", "--format", "PNG"],
                             cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        child.wait(timeout=delay)
        return None, child.returncode, "finished before the signal"
    except subprocess.TimeoutExpired:
        pass
    sent = time.monotonic()
    child.send_signal(signal.SIGTERM)
    out_text, err_text = child.communicate()
    took = time.monotonic() - sent
    last = (err_text.strip().splitlines() or [""])[-1]
    return took, child.returncode, last


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--splats", type=int, default=10_000_000)
    parser.add_argument("--delays", default="5,15,30,45")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(REPO))
    from testing.synth import random_splats, write_ply_variant

    with tempfile.TemporaryDirectory(prefix="stop-bench-") as folder:
        capture = os.path.join(folder, "c.ply")
        write_ply_variant(capture, random_splats(args.splats, degree=0, seed=1))
        print(f"{args.splats:,} splats, degree 0, 1920x1080: SIGTERM DELAY s after start")
        took_all = []
        for delay in (float(d) for d in args.delays.split(",")):
            took, rc, last = stop_after(capture, os.path.join(folder, f"out{delay:g}"), delay)
            if took is None:
                print(f"delay {delay:5.1f} s: {last} (exit {rc})", flush=True)
                continue
            took_all.append(took)
            print(f"delay {delay:5.1f} s: stopped in {took:6.2f} s, exit {rc}: {last}", flush=True)
        if took_all:
            print(f"median stop: {statistics.median(took_all):.2f} s over {len(took_all)} signals")
    return 0


if __name__ == "__main__":
    sys.exit(main())
