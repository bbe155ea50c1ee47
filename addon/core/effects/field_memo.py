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

from .array_memo import ArrayMemo
from .common import field_values


class FieldMemo:
    def __init__(self, size: int = 4):
        self.memo = ArrayMemo(size)

    def get(self, positions: np.ndarray, frame: np.ndarray, kind: str) -> np.ndarray:
        """field_values(positions, frame, kind) (HEIGHT or DISTANCE), read-only."""
        return self.memo.get((positions,), (np.asarray(frame, np.float64).tobytes(), kind),
                             lambda: _read_only(field_values(positions, frame, kind)))

    def clear(self) -> None:
        self.memo.clear()


def _read_only(values: np.ndarray) -> np.ndarray:
    values.flags.writeable = False
    return values


FIELD_VALUES = FieldMemo()
