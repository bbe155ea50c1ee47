"""python -m addon convert IN OUT: any readable format to .ply or .splat."""
from __future__ import annotations

import sys

from ..core.errors import SplatFormatError
from ..core.formats import WRITE_FORMATS, WRITE_MAX_DEGREE, format_for_output, read_with_report, write
from ..core.splats import AXES
from ..core.validate import POLICIES


def configure(parser):
    parser.add_argument("input", help="a .ply, compressed .ply, .splat, .spz, .sog (or a SOG meta.json), .glb or .gltf file")
    parser.add_argument("output", help=f"output path; its extension picks the format ({', '.join(WRITE_FORMATS)})")
    parser.add_argument("--sh-degree", type=int, choices=range(4), default=None,
                        help="keep SH bands up to this degree")
    parser.add_argument("--min-opacity", type=float, default=None,
                        help="drop splats less opaque than this (0..1)")
    parser.add_argument("--max-count", type=int, default=None,
                        help="keep at most this many splats, the most important (opacity x volume)")
    parser.add_argument("--axes", choices=AXES, default=None,
                        help="the input's axis convention when the file misdeclares it (e.g. RUB "
                             "for an spz from Niantic's tools); the output is re-expressed in its own")
    parser.add_argument("--max-splats", type=int, default=None, metavar="N",
                        help="splat budget: refuse a file claiming more than N splats before "
                             "decompressing it (default: what fits in available memory)")
    parser.add_argument("--bad", choices=POLICIES, default="drop",
                        help="splats with NaN/Inf, zero quaternions or scales <= 0: drop (default), "
                             "fix (neutralise: invisible / identity rotation / |scale|) or error")


def _refuse_empty(args, count_in_file: int, count_kept: int) -> None:
    """No output for zero splats, as the Blender importer refuses them: a 0-splat .splat is
    a 0-byte file our own reader rejects, so writing one would only move the error later."""
    if count_in_file == 0:
        raise SplatFormatError(args.input, "holds no splats (0 vertices); nothing to convert")
    if count_kept == 0:
        raise SplatFormatError(args.input, f"no splats left after the options (--min-opacity, "
                                           f"--max-count, --bad) of {count_in_file}")


def run(args) -> int:
    fmt = format_for_output(args.output)  # fail on a bad output name before reading
    splats, report = read_with_report(args.input, sh_degree=args.sh_degree,
                                      min_opacity=args.min_opacity, max_count=args.max_count,
                                      bad=args.bad, axes=args.axes, max_splats=args.max_splats)
    _refuse_empty(args, report.count_in_file, splats.count)
    if report.bad.total:
        print(f"warning: {args.input}: {report.bad.summary()}", file=sys.stderr)
    write(args.output, splats, fmt)
    print(f"{args.input} ({report.format}, {report.count_in_file} splats) -> {args.output} "
          f"({fmt}, {splats.count} splats, SH degree {min(splats.sh_degree, WRITE_MAX_DEGREE[fmt])})")
    return 0
