"""python -m addon info FILE [--json]: count, SH degree, format, axes, bounds, bad values."""
from __future__ import annotations

import json
import os

import numpy as np

from ..core.edit import statistics
from ..core.formats import read_with_report, table


def configure(parser):
    parser.add_argument("file", help=f"a {table.readable_help()} file")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--max-splats", type=int, default=None, metavar="N",
                        help="splat budget: refuse a file claiming more than N splats before "
                             "decompressing it (default: what fits in available memory)")
    parser.add_argument("--stats", action="store_true",
                        help="also min, max, mean, std and NaN/Inf count of each activated quantity "
                             "(x y z, opacity 0..1, linear scales, volume, DC colour r g b)")


def summarize(path, stats=False, max_splats=None) -> dict:
    """What `info` prints, as a dict (bad values are counted, not dropped)."""
    splats, report = read_with_report(path, bad="fix", max_splats=max_splats, keep_replaced=True)
    pos = splats.positions
    if report.bad.replaced is not None:  # the box of the positions the file holds, not of fixes
        rows, originals = report.bad.replaced
        pos = pos.copy()
        pos[rows] = originals.positions
    pos = pos[np.isfinite(pos).all(axis=1)]
    bbox_min = pos.min(axis=0).tolist() if len(pos) else None
    bbox_max = pos.max(axis=0).tolist() if len(pos) else None
    return {
        "file": os.fspath(path), "format": report.format, "count": splats.count,
        "sh_degree": splats.sh_degree, "axes": splats.axes,
        "bbox_min": bbox_min, "bbox_max": bbox_max,
        "bad_values": report.bad.as_dict(),
        "file_bytes": report.file_bytes,
    } | ({"stats": statistics(splats, report.bad.replaced)} if stats else {})


def _fmt_vec(v) -> str:
    return "-" if v is None else "(" + ", ".join(f"{x:.4g}" for x in v) + ")"


def run(args) -> int:
    info = summarize(args.file, getattr(args, "stats", False), args.max_splats)
    if args.json:
        print(json.dumps(info))
        return 0
    bad = info["bad_values"]
    rows = [
        ("file", info["file"]), ("format", info["format"]), ("splats", f"{info['count']:,}"),
        ("SH degree", info["sh_degree"]), ("axes", info["axes"]),
        ("bbox min", _fmt_vec(info["bbox_min"])), ("bbox max", _fmt_vec(info["bbox_max"])),
        ("NaN/Inf splats", bad["nonfinite"]), ("zero quaternions", bad["zero_quaternions"]),
        ("non-positive scales", bad["nonpositive_scales"]),
    ]
    width = max(len(k) for k, _ in rows)
    for key, value in rows:
        print(f"{key:<{width}}  {value}")
    if "stats" in info:
        print(f"\n{'quantity':<10} {'min':>11} {'max':>11} {'mean':>11} {'std':>11} {'NaN/Inf':>8}")
        for name, st in info["stats"].items():
            print(f"{name:<10} " + " ".join(f"{st[k]:>11.4g}" for k in ("min", "max", "mean", "std"))
                  + f" {st['nonfinite']:>8}")
    return 0
