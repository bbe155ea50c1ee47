"""What is computed from arrays, memoized by the arrays themselves.

Scrubbing evaluates the same stack on the same centres and rotations frame after frame, and
much of an effect's work depends only on them (noise lattices and values, height fields,
slerp angles). Entries are keyed by the arrays' identities, held weakly, so an entry goes
when its arrays do (a frame's fresh outputs are never found again) and an id reused by a
new array never hits; plain values (a frame, a frequency) complete the key. The newest
`size` entries are kept. A pure cache: it never changes a result, and callers make the
values read-only.
"""
from __future__ import annotations

import threading
import weakref
from collections import OrderedDict


def read_only(values):
    """values, made read-only (what a memo hands out is shared: no caller may write it)."""
    values.flags.writeable = False
    return values


class ArrayMemo:
    def __init__(self, size: int):
        self.size = size
        self.entries: OrderedDict = OrderedDict()
        self.lock = threading.Lock()  # the viewport and a render thread may share one

    def get(self, arrays: tuple, extra: tuple, compute):
        """compute()'s value for these arrays (by identity) and extra (by value)."""
        key = (tuple(id(a) for a in arrays), extra)
        with self.lock:
            hit = self.entries.get(key)
            if hit is not None and all(ref() is a for ref, a in zip(hit[0], arrays)):
                self.entries.move_to_end(key)
                return hit[1]
        value = compute()
        with self.lock:
            for dead in [k for k, (refs, _) in self.entries.items()
                         if any(ref() is None for ref in refs)]:
                del self.entries[dead]
            self.entries[key] = (tuple(weakref.ref(a) for a in arrays), value)
            while len(self.entries) > self.size:
                self.entries.popitem(last=False)
        return value

    def clear(self) -> None:
        with self.lock:
            self.entries.clear()
