"""Height and distance fields of splat centres (common.field_values), memoized per
positions array.

An effect early in the stack reads the base's centres, the same array every frame, and a
field of them depends only on that array and the field's frame: scrubbing then reuses it
instead of measuring the centres again (noise fields have their own memo, noise.FIELDS).
Keyed by the positions array itself (held weakly, so entries of a frame's fresh centres
go with them); values are read-only.
A pure cache: it never changes a result.
"""
from __future__ import annotations

import numpy as np

from .array_memo import ArrayMemo, read_only
from .common import field_values


class FieldMemo:
    def __init__(self, size: int = 4):
        self.memo = ArrayMemo(size)

    def get(self, positions: np.ndarray, frame: np.ndarray, kind: str) -> np.ndarray:
        """field_values(positions, frame, kind) (HEIGHT or DISTANCE), read-only."""
        return self.memo.get((positions,), (np.asarray(frame, np.float64).tobytes(), kind),
                             lambda: read_only(field_values(positions, frame, kind)))

    def clear(self) -> None:
        self.memo.clear()


FIELD_VALUES = FieldMemo()


def rows_field(splats, rest, frame, kind: str, noise=None):
    """A function of a block of rows (a slice) giving field_values there: slices of the
    memoized whole field (read-only) for the stack's input, whose centres are the same
    array every frame, else computed for the block (a fresh array)."""
    if noise is None and splats.positions is rest:
        whole = FIELD_VALUES.get(splats.positions, frame, kind)
        return lambda part: whole[part]
    return lambda part: field_values(splats.positions[part], frame, kind,
                                     None if noise is None else noise[part])
