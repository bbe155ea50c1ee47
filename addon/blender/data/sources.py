"""The table of splat sources: where an object's splats come from at a frame.

One `SplatSource` row (source_kind.py) per kind of source, declared beside its code; the
first row that applies to an object provides its splats, so the stored PointCloud, which
any object with splat attributes has, comes last. The evaluator, the viewport, Blender
5.3's handoff and `is_splat_object` ask this table; none of them names a source.
A new source: a module that declares its `ROW`, and one line in `ROWS` below.
"""
from __future__ import annotations

import contextlib

from . import dynamic_source, sequence_source, stored_splats
from .pointcloud import CASTER_MARK, COMPANION_MARK
from .source_kind import SplatSource

# Most specific first: a sequence object may also hold splat attributes of its own.
ROWS: list[SplatSource] = [sequence_source.ROW, dynamic_source.ROW, stored_splats.ROW]


def source_of(obj) -> SplatSource | None:
    """The row that provides the object's splats, or None for an object that has none."""
    return next((row for row in ROWS if row.applies(obj)), None)


def is_splat_object(obj, *, with_splat_data: bool = False) -> bool:
    """THE splat-object test, for every operator, panel and evaluator.

    A POINTCLOUD object whose data has radiance:base (Splatline's imports and Blender 5.3's
    own), or one whose splats come from a source of their own (a sequence's files): its own
    data may then hold none. with_splat_data=True keeps only the first kind, for callers
    that read the object's own attributes (export, camera framing, the sequence operators)."""
    if obj is None or obj.type != "POINTCLOUD" or COMPANION_MARK in obj.keys() or CASTER_MARK in obj.keys():
        return False
    if stored_splats.holds_splats(obj):
        return True
    return not with_splat_data and source_of(obj) is not None


@contextlib.contextmanager
def registered(row: SplatSource):
    """The table with `row` first while the block runs (tests' throwaway sources)."""
    if any(other.id == row.id for other in ROWS):
        raise ValueError(f"splat source {row.id}: the table already has one")
    ROWS.insert(0, row)
    try:
        yield row
    finally:
        ROWS.remove(row)
