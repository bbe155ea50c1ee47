"""The options several sub-commands share, defined once: the same name, values, default and
help everywhere (tests/cli/test_cli_vocabulary.py walks every parser to hold them so)."""
from __future__ import annotations

from ..core.splats import AXES

AXES_CHOICES = ("AUTO",) + AXES


def add_axes(parser, blend_input: bool = False) -> None:
    """--axes: the input's axis convention, AUTO (the file's own) by default."""
    parser.add_argument("--axes", type=str.upper, default="AUTO", choices=AXES_CHOICES,
                        help="the input's axis convention: AUTO (default) takes the format's own "
                             "(RDF for .ply, .splat, .sog and glTF; RUB for .spz, or what its "
                             "coordinate-system extension names); RDF for an .spz that holds the "
                             "PLY's values (splat-transform 3.7 writes them so)"
                             + ("; for a .blend object, the frame its data is in (RFU for one "
                                "Blender's own SPZ importer made)" if blend_input else ""))


def axes_or_none(text: str):
    """The override core.formats.read takes: None for AUTO."""
    return None if text == "AUTO" else text
