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

import threading
import weakref
from collections import OrderedDict

import numpy as np

from .common import field_values


class FieldMemo:
    def __init__(self, size: int = 4):
        self.size = size
        self.entries: OrderedDict = OrderedDict()
        self.lock = threading.Lock()

    def get(self, positions: np.ndarray, frame: np.ndarray, kind: str) -> np.ndarray:
        """field_values(positions, frame, kind) (HEIGHT or DISTANCE), read-only."""
        key = (id(positions), np.asarray(frame, np.float64).tobytes(), kind)
        with self.lock:
            hit = self.entries.get(key)
            if hit is not None and hit[0]() is positions:
                self.entries.move_to_end(key)
                return hit[1]
        values = field_values(positions, frame, kind)
        values.flags.writeable = False
        with self.lock:
            for dead in [k for k, (ref, _) in self.entries.items() if ref() is None]:
                del self.entries[dead]
            self.entries[key] = (weakref.ref(positions), values)
            while len(self.entries) > self.size:
                self.entries.popitem(last=False)
        return values

    def clear(self) -> None:
        with self.lock:
            self.entries.clear()


FIELD_VALUES = FieldMemo()
