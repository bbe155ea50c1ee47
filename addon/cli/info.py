"""python -m addon info FILE [--json]: count, SH degree, format, axes, whether the capture was
trained with anti-aliasing, bounds, bad values."""
from __future__ import annotations

import json
import os

import numpy as np

from ..core.dynamic import is_dynamic_file
from ..core.edit import statistics
from ..core.formats import read_with_report, table
from . import dynamic_capture
from .options import add_axes, add_lod, add_max_splats, axes_or_none


def configure(parser):
    parser.add_argument("file", help=f"a {table.readable_help()} file")
    parser.add_argument("--json", action="store_true", help="print one JSON object (default: a table)")
    add_max_splats(parser)
    add_lod(parser)
    add_axes(parser)
    parser.add_argument("--stats", action="store_true",
                        help="also min, max, mean, std and NaN/Inf count of each activated quantity "
                             "(x y z, opacity 0..1, linear scales, volume, DC colour r g b; default: off)")


def summarize(path, stats=False, max_splats=None, axes=None, lod=None) -> dict:
    """What `info` prints, as a dict (bad values are counted, not dropped); `axes` overrides
    the file's convention (the bounds are the file's values either way). A file with levels
    of detail lists them; the rest describes the level read (`lod`, default the finest)."""
    splats, report = read_with_report(path, bad="fix", max_splats=max_splats, axes=axes,
                                      keep_replaced=True, lod=lod)
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
        "sh_degree": splats.sh_degree, "axes": splats.axes, "antialiased": splats.antialiased,
        "bbox_min": bbox_min, "bbox_max": bbox_max,
        "bad_values": report.bad.as_dict(),
        "file_bytes": report.file_bytes,
    } | ({"levels": report.levels, "level": report.level} if report.levels is not None else {}) | ({"stats": statistics(splats, report.bad.replaced)} if stats else {})


def _levels(info) -> list:
    """The levels of detail rows: every level's count, and which one the rest describes."""
    if "levels" not in info:
        return []
    listed = ", ".join(f"{lod}: {'?' if n is None else f'{n:,}'}" for lod, n in enumerate(info["levels"]))
    return [("levels", f"{len(info['levels'])} ({listed} splats; 0 is the finest)"),
            ("level read", f"{info['level']} (--lod N reads another)")]


def _fmt_vec(v) -> str:
    return "-" if v is None else "(" + ", ".join(f"{x:.4g}" for x in v) + ")"


def run(args) -> int:
    stats = getattr(args, "stats", False)
    if is_dynamic_file(args.file):
        info = dynamic_capture.summary(args.file, stats, args.max_splats)
        print(json.dumps(info)) if args.json else dynamic_capture.print_summary(info)
        return 0
    info = summarize(args.file, stats, args.max_splats, axes_or_none(args.axes), args.lod)
    if args.json:
        print(json.dumps(info))
        return 0
    bad = info["bad_values"]
    rows = [
        ("file", info["file"]), ("format", info["format"]), *_levels(info), ("splats", f"{info['count']:,}"),
        ("SH degree", info["sh_degree"]), ("axes", info["axes"]),
        ("anti-aliased", "yes (trained so: rendered with the compensation)" if info["antialiased"] else "no"),
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
