"""The options several sub-commands share, defined once: the same name, values, default and
help everywhere (tests/cli/test_cli_vocabulary.py walks every parser and holds them so).

Old spellings kept as hidden aliases (not in --help, the same destination): `convert --bad`
(now --bad-values) and `convert --sh-degree` (now --max-sh-degree).
"""
from __future__ import annotations

import argparse
import os

from ..core.splats import AXES
from ..core.validate import POLICIES

AXES_CHOICES = ("AUTO",) + AXES
BAD_VALUES_DEFAULT = "fix"
PRESETS = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                       "presets")


def add_axes(parser, blend_input: bool = False) -> None:
    """--axes: the input's axis convention, AUTO (the file's own) by default."""
    parser.add_argument("--axes", type=str.upper, default="AUTO", choices=AXES_CHOICES,
                        help="the input's axis convention: AUTO (default) takes the format's own "
                             "(RDF for .ply, .splat, .sog and glTF; RUB for .spz, or what its "
                             "coordinate-system extension names; RFU for .lcc and .lcc2); RDF for "
                             "an .spz that holds the PLY's values (splat-transform 3.7 writes them so)"
                             + ("; for a .blend object, the frame its data is in (RFU for one "
                                "Blender's own SPZ importer made)" if blend_input else ""))


def axes_or_none(text: str):
    """The override core.formats.read takes: None for AUTO."""
    return None if text == "AUTO" else text


def add_bad_values(parser, alias: str | None = None) -> None:
    """--bad-values: what to do with NaN/Inf splats, zero quaternions and scales <= 0."""
    parser.add_argument("--bad-values", choices=POLICIES, default=BAD_VALUES_DEFAULT,
                        help="splats with NaN/Inf values, zero quaternions or scales <= 0: fix "
                             "(default: neutralise them as INRIA's renderer draws them: invisible, "
                             "identity rotation, |scale|; the count and order stay), drop or error")
    if alias:
        parser.add_argument(alias, dest="bad_values", choices=POLICIES, help=argparse.SUPPRESS)


def add_selection(parser, sh_alias: str | None = None) -> None:
    """--max-sh-degree, --min-opacity, --max-count and --max-splats: which splats are kept."""
    parser.add_argument("--max-sh-degree", type=int, default=3, choices=range(4), metavar="N",
                        help="keep SH bands up to N, 0..3 (default 3: all Splatline renders)")
    if sh_alias:
        parser.add_argument(sh_alias, dest="max_sh_degree", type=int, choices=range(4), help=argparse.SUPPRESS)
    parser.add_argument("--min-opacity", type=float, default=0.0, metavar="X",
                        help="drop splats less opaque than X, 0..1 (default 0: keep all)")
    parser.add_argument("--max-count", type=int, default=0, metavar="N",
                        help="keep the N most important splats (opacity x volume) of each input "
                             "(default 0: all)")
    add_max_splats(parser)


def add_max_splats(parser) -> None:
    parser.add_argument("--max-splats", type=int, default=None, metavar="N",
                        help="splat budget: refuse a file claiming more than N splats before "
                             "decompressing it (default: what fits in available memory)")


def add_lod(parser) -> None:
    """--lod: which level of detail of a file that holds several."""
    parser.add_argument("--lod", type=int, default=None, metavar="N",
                        help="the level of detail to read from a file holding several (a streamed "
                             "SOG lod-meta.json, .lcc, .lcc2): 0 is the finest (default: the finest); "
                             "`info` lists a file's levels; a file of one level has level 0 only")


def check_selection(args, usage_error) -> None:
    """The ranges argparse cannot say (usage_error: the command's UsageError)."""
    if not 0.0 <= args.min_opacity <= 1.0:
        raise usage_error(f"--min-opacity {args.min_opacity:g}: must be in 0-1")
    if args.max_count < 0:
        raise usage_error(f"--max-count {args.max_count}: must be 0 (all) or more")


def preset_names(kind: str, ext: str) -> str:
    """The bundled presets of a kind, for --help ('' where the folder is missing)."""
    try:
        names = sorted(n[:-len(ext)] for n in os.listdir(os.path.join(PRESETS, kind)) if n.endswith(ext))
    except OSError:
        return ""
    return ", ".join(names)
