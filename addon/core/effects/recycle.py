"""Big output arrays (a morph's sh_rest: 180 MB per million degree-3 splats) from buffers
that nothing refers to any more.

An array that large is fresh memory from the system each frame (beyond malloc's reuse), and
the system zeroes every page on first touch: 13 ms per 180 MB here, half a morph's lerp.
Kernels still return new arrays (copy-on-write): `empty` hands out a view of a kept buffer
only when no array handed out before still refers to it, as the buffer's reference count
says (every view, and every view of a view, holds the buffer itself as its base), and no
weak reference to it exists. A caller never sees data it holds change. A pure cache:
results never depend on it; it keeps at most `size` buffers alive (clear() frees them).
"""
from __future__ import annotations

import math
import sys
import threading
import weakref

import numpy as np

MIN_BYTES = 32 << 20   # below this, malloc reuses freed memory itself (glibc's mmap threshold)


def _refs(buffers: list, i: int) -> int:
    return sys.getrefcount(buffers[i])


_UNHELD = _refs([np.empty(0)], 0)   # the count of a buffer only the pool's list holds


class Recycler:
    def __init__(self, size: int = 2):
        self.size = size
        self.buffers: list = []   # least recently handed out first
        self.lock = threading.Lock()

    def empty(self, shape, dtype=np.float32) -> np.ndarray:
        """An uninitialised C-contiguous array, as np.empty (a view of a free kept buffer
        for big ones)."""
        shape, dtype = tuple(shape), np.dtype(dtype)
        if math.prod(shape) * dtype.itemsize < MIN_BYTES:
            return np.empty(shape, dtype)
        with self.lock:
            for i in range(len(self.buffers)):
                if self.buffers[i].shape == shape and self.buffers[i].dtype == dtype \
                        and self._unheld(i):
                    self.buffers.append(self.buffers.pop(i))
                    self.buffers[-1].flags.writeable = True  # a caller may have frozen it
                    return self.buffers[-1][...]
            self.buffers.append(np.empty(shape, dtype))
            view = self.buffers[-1][...]
            del self.buffers[:-self.size]
            return view

    def _unheld(self, i: int) -> bool:
        return _refs(self.buffers, i) == _UNHELD and weakref.getweakrefcount(self.buffers[i]) == 0

    def clear(self) -> None:
        with self.lock:
            self.buffers.clear()


BUFFERS = Recycler()
