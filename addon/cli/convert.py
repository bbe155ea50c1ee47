"""python -m addon convert IN [IN ...] OUT [edits]: any readable format(s) to any writable
one; several inputs merge into one output. Edit flags: cli/edits.py.

An input may be a .blend: its splat objects named by --object (cli/blend_objects.py) are
written as File > Export writes them, so an object Blender 5.3 imported itself converts to
every format Splatline writes."""
from __future__ import annotations

import sys

from ..core import budget
from ..core.dynamic import is_dynamic_file
from ..core.errors import SplatFormatError
from ..core.formats._common import splat_bytes
from ..core.formats import format_for_output, read_with_report, table, write
from ..core.select import select
from ..core.validate import check_values
from ..core.edit import merge
from . import UsageError, dynamic_capture, edits
from .capture_scene import is_blend
from .options import add_axes, add_bad_values, add_lod, add_selection, axes_or_none, check_selection
from .writable import check_output_file


def configure(parser):
    parser.add_argument("input", nargs="+", help=f"a {table.readable_help()} file, or a .blend whose "
                        "splat objects --object names; several are merged into one output")
    writable = ", ".join(r.name for r in table.rows(writable=True))
    parser.add_argument("output", help=f"output path; its extension picks the format ({writable}; "
                                       "a path named meta.json writes an unbundled SOG beside it)")
    parser.add_argument("--spz-version", type=int, choices=(3, 4), default=4,
                        help="SPZ version to write: 4 (zstd streams, default) or 3 (gzip)")
    add_axes(parser, blend_input=True)
    add_lod(parser)
    parser.add_argument("--object", action="append", default=[], metavar="NAME",
                        help="a splat object of the .blend input to write, its stored data "
                             "object-local as File > Export writes it (repeatable: several merge; "
                             "default: the .blend's one splat object)")
    add_selection(parser, sh_alias="--sh-degree")
    add_bad_values(parser, alias="--bad")
    dynamic = parser.add_argument_group("dynamic (4D) captures")
    dynamic.add_argument("--time", type=float, default=None, metavar="T",
                         help="bake the capture at its time T (its own unit) to a static file "
                              "(default: none, a dynamic output)")
    dynamic.add_argument("--frames", default=None, metavar="A-B",
                         help="bake scene frames A-B to a numbered sequence (the output names "
                              "each file with #'s), the capture's time 0 at frame 1 (default: none)")
    dynamic.add_argument("--fps", metavar="N",
                         help="scene frame rate for --frames (default 24): a capture in seconds "
                              "plays in real time, a Spacetime segment spans 50 frames")
    dynamic.add_argument("--seconds-per-unit", type=float, default=None, metavar="S",
                         help="to .4dgs from segment time: seconds one segment lasts, e.g. "
                              "1.6667 for 50 frames at 30 fps (default: none, refused)")
    edits.add_arguments(parser)


def _refuse_empty(path, count_in_file: int, count_kept: int) -> None:
    """No output for zero splats, as the Blender importer refuses them: a 0-splat .splat is
    a 0-byte file our own reader rejects, so writing one would only move the error later."""
    if count_in_file == 0:
        raise SplatFormatError(path, "holds no splats (0 vertices); nothing to convert")
    if count_kept == 0:
        raise SplatFormatError(path, f"no splats left after the options of {count_in_file}")


def _read(args, path):
    if is_blend(path):
        return [_checked(*_options(args, s, r)) for s, r in _blend_objects(args, path)]
    splats, report = read_with_report(path, sh_degree=args.max_sh_degree,
                                      min_opacity=args.min_opacity or None,
                                      max_count=args.max_count or None, bad=args.bad_values,
                                      axes=axes_or_none(args.axes), max_splats=args.max_splats,
                                      lod=args.lod)
    return [_checked(splats, report)]


def _checked(splats, report):
    _refuse_empty(report.path, report.count_in_file, splats.count)
    if report.bad.total:
        print(f"warning: {report.path}: {report.bad.summary()}", file=sys.stderr)
    return splats, report


def _blend_objects(args, path):
    from .blend_objects import read_objects

    return read_objects(path, args.object, axes_or_none(args.axes))


def _options(args, splats, report):
    """What read_with_report does after decoding, for splats read from a .blend object."""
    splats, report.bad = check_values(splats, args.bad_values, report.path)
    kept = select(splats, args.max_sh_degree, args.min_opacity or None, args.max_count or None)
    return kept.check(), report


def _level(report) -> str:
    """'level 1 of 3, ' for a file with levels of detail, else ''."""
    return f"level {report.level} of {len(report.levels)}, " if report.levels else ""


def _check_inputs(args) -> None:
    blends = [p for p in args.input if is_blend(p)]
    if len(blends) > 1:
        raise UsageError(f"one .blend input at a time, not {len(blends)} ({', '.join(blends)})")
    if args.object and not blends:
        raise UsageError("--object names splat objects of a .blend input; none was given")


def run(args) -> int:
    dynamic = [p for p in args.input if is_dynamic_file(p)]
    if dynamic:
        return dynamic_capture.convert(args, dynamic[0])
    if args.time is not None or args.frames is not None:
        raise UsageError("--time and --frames bake a dynamic (4D) capture; "
                         f"{', '.join(args.input)} holds none")
    fmt = format_for_output(args.output)  # fail on a bad output name or flag before reading
    check_selection(args, UsageError)
    edits.check(args)
    _check_inputs(args)
    check_output_file(args.output, f"the {fmt} output")
    # the writer's encoding, and a merge's copy, counted by each read's own check
    merged = 1 if len(args.input) > 1 else 0
    budget.after_read(lambda n, rest: table.row(fmt).write_cost(n, rest) + merged * splat_bytes(n, rest))
    loaded = [item for path in args.input for item in _read(args, path)]
    splats = merge([s for s, _ in loaded]) if len(loaded) > 1 else loaded[0][0]
    total = sum(r.count_in_file for _, r in loaded)
    splats = edits.apply(args, splats)
    _refuse_empty(", ".join(args.input), total, splats.count)
    notes = write(args.output, splats, fmt, **({"version": args.spz_version} if fmt == "spz" else {}))
    for note in notes:
        print(f"warning: {args.output}: {note}", file=sys.stderr)
    source = ", ".join(f"{r.path} ({r.format}, {_level(r)}{r.count_in_file} splats)" for _, r in loaded)
    print(f"{source} -> {args.output} "
          f"({fmt}, {splats.count} splats, SH degree {min(splats.sh_degree, table.row(fmt).max_sh_degree)})")
    return 0
