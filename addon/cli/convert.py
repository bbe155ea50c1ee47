"""python -m addon convert IN [IN ...] OUT [edits]: any readable format(s) to any writable
one; several inputs merge into one output. Edit flags: cli/edits.py."""
from __future__ import annotations

import sys

from ..core.errors import SplatFormatError
from ..core.formats import WRITE_FORMATS, WRITE_MAX_DEGREE, format_for_output, read_with_report, write
from ..core.splats import AXES
from ..core.validate import POLICIES
from ..core.edit import merge
from . import edits


def configure(parser):
    parser.add_argument("input", nargs="+", help="a .ply, compressed .ply, .splat, .spz, .sog (or a SOG "
                        "meta.json), .glb or .gltf file; several are merged into one output")
    parser.add_argument("output", help=f"output path; its extension picks the format ({', '.join(WRITE_FORMATS)}; "
                                       "a path named meta.json writes an unbundled SOG beside it)")
    parser.add_argument("--spz-version", type=int, choices=(3, 4), default=4,
                        help="SPZ version to write: 4 (zstd streams, default) or 3 (gzip)")
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
    edits.add_arguments(parser)


def _refuse_empty(path, count_in_file: int, count_kept: int) -> None:
    """No output for zero splats, as the Blender importer refuses them: a 0-splat .splat is
    a 0-byte file our own reader rejects, so writing one would only move the error later."""
    if count_in_file == 0:
        raise SplatFormatError(path, "holds no splats (0 vertices); nothing to convert")
    if count_kept == 0:
        raise SplatFormatError(path, f"no splats left after the options of {count_in_file}")


def _read(args, path):
    splats, report = read_with_report(path, sh_degree=args.sh_degree, min_opacity=args.min_opacity,
                                      max_count=args.max_count, bad=args.bad, axes=args.axes,
                                      max_splats=args.max_splats)
    _refuse_empty(path, report.count_in_file, splats.count)
    if report.bad.total:
        print(f"warning: {path}: {report.bad.summary()}", file=sys.stderr)
    return splats, report


def run(args) -> int:
    fmt = format_for_output(args.output)  # fail on a bad output name or flag before reading
    edits.check(args)
    loaded = [_read(args, path) for path in args.input]
    splats = merge([s for s, _ in loaded]) if len(loaded) > 1 else loaded[0][0]
    total = sum(r.count_in_file for _, r in loaded)
    splats = edits.apply(args, splats)
    _refuse_empty(", ".join(args.input), total, splats.count)
    write(args.output, splats, fmt, **({"version": args.spz_version} if fmt == "spz" else {}))
    source = ", ".join(f"{p} ({r.format}, {r.count_in_file} splats)" for p, (_, r) in zip(args.input, loaded))
    print(f"{source} -> {args.output} "
          f"({fmt}, {splats.count} splats, SH degree {min(splats.sh_degree, WRITE_MAX_DEGREE[fmt])})")
    return 0
