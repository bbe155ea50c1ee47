"""The edit flags `convert` shares with splat-transform's actions: one parser group here,
the logic in core/edit.py. Applied in a fixed order: transform, then filters, then SH
bands, then decimation, so a box or sphere is given in the output's coordinates."""
from __future__ import annotations

from ..core import edit
from . import UsageError


def add_arguments(parser) -> None:
    g = parser.add_argument_group("edits (applied in this order)")
    g.add_argument("--translate", nargs=3, type=float, metavar=("X", "Y", "Z"),
                   help="move every splat by X Y Z, after --rotate and --scale (default: no move)")
    g.add_argument("--rotate", nargs=3, type=float, metavar=("X", "Y", "Z"),
                   help="turn by X, then Y, then Z degrees about the origin (SH colour turns too; "
                        "default: no turn)")
    g.add_argument("--scale", type=float, metavar="S", help="grow positions and sizes by S about the origin (default 1)")
    g.add_argument("--keep-box", nargs=6, type=float, metavar=("X0", "Y0", "Z0", "X1", "Y1", "Z1"),
                   help="keep splats whose centre lies in the box from X0 Y0 Z0 to X1 Y1 Z1 "
                        "(default: no box)")
    g.add_argument("--keep-sphere", nargs=4, type=float, metavar=("X", "Y", "Z", "R"),
                   help="keep splats whose centre lies within R of X Y Z (default: no sphere)")
    g.add_argument("--keep-where", action="append", default=[], metavar="TEST",
                   help="keep splats passing TEST, e.g. 'opacity>0.05' or 'scale<2'; quantities: "
                        f"{', '.join(edit.COLUMNS)} (activated: opacity 0..1, linear scales); repeatable (default: none)")
    g.add_argument("--decimate", metavar="N|P%",
                   help="keep the N (or P percent) most important splats (opacity x volume; "
                        "default: all)")


def check(args) -> None:
    """Refuse bad values before any file is read, one line each."""
    try:
        for test in args.keep_where:
            edit.parse_test(test)
        if args.decimate is not None:
            edit.parse_count(args.decimate, 1)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if args.scale is not None and not args.scale > 0:
        raise UsageError(f"--scale must be a positive number, not {args.scale}")
    if args.keep_sphere is not None and args.keep_sphere[3] < 0:
        raise UsageError(f"--keep-sphere radius must be >= 0, not {args.keep_sphere[3]}")


def apply(args, splats):
    if args.translate or args.rotate or args.scale is not None:
        splats = edit.transform(splats, args.translate or (0, 0, 0), args.rotate or (0, 0, 0),
                                1.0 if args.scale is None else args.scale)
    if args.keep_box is not None:
        splats = edit.keep_box(splats, args.keep_box[:3], args.keep_box[3:])
    if args.keep_sphere is not None:
        splats = edit.keep_sphere(splats, args.keep_sphere[:3], args.keep_sphere[3])
    for test in args.keep_where:
        splats = edit.keep_where(splats, test)
    if args.decimate is not None:
        splats = edit.decimate(splats, edit.parse_count(args.decimate, splats.count))
    return splats
