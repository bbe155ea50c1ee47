"""The memory budget against measured peaks: for each command on a generated capture, the
largest peak the budget's estimates foresaw (core/budget.largest_estimate: resident set +
what each check allowed) beside the command's measured peak (VmHWM of its process). The
estimate must be the larger on every row (ratio >= 1).

    python -m bench.memory_budget_bench [--splats 1000000] [--only info,convert,...]

Each row is a fresh process running the command line in-process. The captures (INRIA PLY,
degree 0 and 3) are generated into a temporary folder and removed after.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

from testing.paths import REPO

_CHILD = r"""
import json, sys
sys.argv = ["python -m addon"] + sys.argv[1:]
from addon.__main__ import main
from addon.core import budget
rc = main(sys.argv[1:])
hwm = 0
for line in open("/proc/self/status"):
    if line.startswith("VmHWM:"):
        hwm = int(line.split()[1]) * 1024
print("BENCH " + json.dumps({"rc": rc, "estimate": budget.largest_estimate(), "peak": hwm}))
"""

OUTPUTS = ("ply", "compressed.ply", "splat", "spz", "sog", "glb", "gltf")


def cases(folder, splats: int):
    for degree in (0, 3):
        src = os.path.join(folder, f"d{degree}.ply")
        yield f"info d{degree}", ["info", src]
        yield f"info --stats d{degree}", ["info", "--stats", src]
        for ext in OUTPUTS:
            yield f"convert d{degree} -> .{ext}", ["convert", src, os.path.join(folder, f"out.{ext}")]
        yield f"import d{degree}", ["import", src, "--blend", os.path.join(folder, "out.blend")]
        for size in ("1920x1080", "3840x2160"):
            yield f"render d{degree} {size}", ["render", src, "--out", os.path.join(folder, "frames"),
                                               "--frames", "1", "--resolution", size, "--format", "PNG"]


def run_case(argv) -> dict:
    r = subprocess.run([sys.executable, "-c", _CHILD, *argv], cwd=REPO, capture_output=True, text=True)
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith("BENCH ")]
    if not lines:
        return {"rc": r.returncode, "estimate": 0, "peak": 0, "err": r.stderr[-300:]}
    return json.loads(lines[-1][6:])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--splats", type=int, default=1_000_000)
    parser.add_argument("--only", default="", help="comma-separated case prefixes (info, convert, import, render)")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(REPO))
    from testing.synth import random_splats, write_ply_variant

    with tempfile.TemporaryDirectory(prefix="budget-bench-") as folder:
        for degree in (0, 3):
            write_ply_variant(os.path.join(folder, f"d{degree}.ply"), random_splats(args.splats, degree=degree, seed=1))
        print(f"{args.splats:,} splats; MiB; ratio = estimate / measured peak (must be >= 1)")
        print(f"{'case':34} {'estimate':>9} {'peak':>9} {'ratio':>6}  rc")
        worst = None
        for name, argv in cases(folder, args.splats):
            if args.only and not any(name.startswith(p) for p in args.only.split(",")):
                continue
            r = run_case(argv)
            ratio = r["estimate"] / r["peak"] if r["peak"] else 0.0
            worst = ratio if worst is None else min(worst, ratio)
            print(f"{name:34} {r['estimate'] / 2**20:9.0f} {r['peak'] / 2**20:9.0f} {ratio:6.2f}  {r['rc']}"
                  + (f"  {r.get('err', '').strip()[-200:]}" if r["rc"] else ""), flush=True)
        print(f"lowest ratio: {worst:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
