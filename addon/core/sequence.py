"""Splat sequences without bpy: numbered-file discovery, time -> frame mapping, frame cache.

A sequence is `directory/prefix + number + suffix` for a contiguous range of numbers.
A number in the range without a file is a *missing* frame (shown by holding the previous
available one), as Blender does for image sequences; numbers sort numerically, so
frame_2 comes before frame_10 whatever the zero padding.
"""
from __future__ import annotations

import math
import os
import re
import threading
from collections import OrderedDict
from dataclasses import dataclass

from .errors import SplatFormatError
from .splats import ARRAYS

HOLD, LOOP, PING_PONG = "HOLD", "LOOP", "PING_PONG"
LOOP_MODES = (HOLD, LOOP, PING_PONG)

# (prefix)(digits)(suffix starting with the extension): the LAST run of digits before
# the extension is the frame number, so "take2_frame_0007.ply" numbers by 0007.
_NUMBERED = re.compile(r"^(.*?)(\d+)(\D*\.[A-Za-z0-9]+)$")
# Snap to the integer below when the mapped time is within this of the integer above:
# (t - start) * speed accumulates float64 rounding (e.g. 3 * 0.1 = 0.30000000000000004,
# 0.7 / 0.1 * 0.1 = 0.6999999999999999); 1e-6 frame is far below any meaningful time step.
_SNAP = 1e-6


@dataclass(frozen=True)
class SequencePattern:
    """Where the frames of a sequence live; frame index k is file number first + k."""

    directory: str
    prefix: str
    suffix: str
    digits: int     # zero-padding width (1 = unpadded)
    first: int
    count: int

    def filename(self, index: int) -> str:
        return f"{self.prefix}{str(self.first + index).zfill(self.digits)}{self.suffix}"

    def path(self, index: int) -> str:
        return os.path.join(self.directory, self.filename(index))


def split_numbered(name: str):
    """(prefix, number string, suffix) of a numbered file name, or None."""
    m = _NUMBERED.match(name)
    return (m.group(1), m.group(2), m.group(3)) if m else None


def _pattern_from(directory, prefix, suffix, numbers) -> SequencePattern:
    strings = sorted(numbers, key=int)
    first, last = int(strings[0]), int(strings[-1])
    # zfill to the first number's width re-creates padded ("0001") and unpadded ("1") names
    return SequencePattern(directory, prefix, suffix, len(strings[0]), first, last - first + 1)


def discover(path, extensions=(".ply", ".splat", ".spz")) -> SequencePattern:
    """The sequence a folder or one of its numbered files belongs to.

    A folder: the (prefix, suffix) group with the most numbered files of a known extension
    (ties broken by name, so the choice is stable). A file: the group it belongs to.
    """
    path = os.fspath(path)
    if os.path.isdir(path):
        directory, wanted = path, None
    elif os.path.isfile(path):
        directory, name = os.path.split(path)
        wanted = split_numbered(name)
        if wanted is None:
            raise SplatFormatError(path, "file name has no frame number to infer a sequence from")
    else:
        raise SplatFormatError(path, "no such file or folder")
    groups: dict = {}
    for name in os.listdir(directory or "."):
        parts = split_numbered(name)
        if parts is None or os.path.splitext(name)[1].lower() not in extensions:
            continue
        groups.setdefault((parts[0], parts[2]), []).append(parts[1])
    if wanted is not None:
        key = (wanted[0], wanted[2])
    elif groups:
        key = max(sorted(groups), key=lambda k: len(groups[k]))
    else:
        raise SplatFormatError(path, f"folder holds no numbered splat files ({', '.join(extensions)})")
    return _pattern_from(directory, key[0], key[1], groups[key])


def frame_index(time: float, count: int, start: float = 1.0, speed: float = 1.0,
                offset: float = 0.0, mode: str = HOLD) -> int:
    """Frame index in [0, count) shown at scene time `time` (frames, may be fractional).

    local = (time - start) * speed + offset, floored; speed 0 freezes on frame `offset`.
    HOLD clamps to the ends, LOOP wraps, PING_PONG runs 0..n-1..1 0..n-1 (period 2n-2).
    """
    if count <= 0:
        raise ValueError("a sequence has at least one frame")
    local = (time - start) * speed + offset
    if not math.isfinite(local):
        return 0
    k = math.floor(local + _SNAP)
    if mode == LOOP:
        return k % count
    if mode == PING_PONG:
        if count == 1:
            return 0
        m = k % (2 * count - 2)
        return m if m < count else 2 * count - 2 - m
    if mode == HOLD:
        return min(max(k, 0), count - 1)
    raise ValueError(f"unknown loop mode {mode!r}; known: {', '.join(LOOP_MODES)}")


def splats_nbytes(splats) -> int:
    return sum(getattr(splats, n).nbytes for n in ARRAYS)


class FrameCache:
    """LRU cache of decoded frames bounded by a byte budget; thread-safe.

    Pinned keys (each object's current frame) are never evicted, so the budget holds for
    everything else: the current frames plus read-ahead stay within budget unless one
    current frame alone is larger, in which case only the pinned frames are kept.
    """

    def __init__(self, budget_bytes: int):
        self.budget = int(budget_bytes)
        self._entries: OrderedDict = OrderedDict()  # key -> (signature, splats, nbytes)
        self._pinned: dict = {}                      # owner -> key
        self._lock = threading.Lock()
        self.nbytes = 0

    def get(self, key, signature=None):
        with self._lock:
            entry = self._entries.get(key)
            if entry is None or (signature is not None and entry[0] != signature):
                return None
            self._entries.move_to_end(key)
            return entry[1]

    def __contains__(self, key) -> bool:
        with self._lock:
            return key in self._entries

    def keys(self) -> list:
        with self._lock:
            return list(self._entries)

    def put(self, key, splats, signature=None, owner=None) -> None:
        """Insert (replacing) key; with owner, also pin it as that owner's current frame
        before evicting, so a current frame larger than the budget is still kept."""
        size = splats_nbytes(splats)
        with self._lock:
            if owner is not None:
                self._pinned[owner] = key
            old = self._entries.pop(key, None)
            if old is not None:
                self.nbytes -= old[2]
            self._entries[key] = (signature, splats, size)
            self.nbytes += size
            self._evict()

    def fits(self, extra: int) -> bool:
        with self._lock:
            return self.nbytes + extra <= self.budget

    def pin(self, owner, key) -> None:
        with self._lock:
            self._pinned[owner] = key
            self._evict()

    def unpin(self, owner) -> None:
        with self._lock:
            self._pinned.pop(owner, None)

    def unpin_all(self) -> None:
        with self._lock:
            self._pinned.clear()
            self._evict()

    def set_budget(self, budget_bytes: int) -> None:
        with self._lock:
            self.budget = int(budget_bytes)
            self._evict()

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()
            self._pinned.clear()
            self.nbytes = 0

    def _evict(self) -> None:
        pinned = set(self._pinned.values())
        for key in list(self._entries):
            if self.nbytes <= self.budget:
                break
            if key not in pinned:
                self.nbytes -= self._entries.pop(key)[2]


def file_signature(path):
    """(mtime, size) of a file, so a re-baked frame is not served stale; None if absent."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_mtime_ns, st.st_size)


class ReadAhead:
    """One background thread that decodes upcoming frames into a FrameCache.

    Only ever a hint: the caller still loads its current frame itself when it is not
    cached, so what is shown never depends on the thread's timing. `request` replaces the
    pending list (scrubbing makes old requests stale); `stop` joins the thread.
    """

    def __init__(self, cache: FrameCache, load):
        self.cache = cache
        self._load = load
        self._pending: list = []   # (key, path, nbytes estimate)
        self._cond = threading.Condition()
        self._stopping = False
        self._busy = False
        self._loading = None       # key being decoded right now
        self._thread = None

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def request(self, jobs) -> None:
        with self._cond:
            if self._stopping:
                return
            self._pending = list(jobs)
            if self._thread is None:
                # daemon as well: a Python exit without unregister must not hang on it
                self._thread = threading.Thread(target=self._run, name="splatline-readahead", daemon=True)
                self._thread.start()
            self._cond.notify()

    def wait_idle(self, timeout: float = 10.0) -> bool:
        """Block until no job is pending or running (tests and benchmarks)."""
        with self._cond:
            return self._cond.wait_for(lambda: not self._pending and not self._busy, timeout)

    def wait_if_loading(self, key, timeout: float = 60.0) -> None:
        """If the thread is decoding key right now, wait for it rather than decode it twice
        (the second decode would also compete with the first for the CPU)."""
        with self._cond:
            self._cond.wait_for(lambda: self._loading != key, timeout)

    def stop(self) -> None:
        with self._cond:
            self._stopping = True
            self._pending = []
            self._cond.notify_all()
        if self._thread is not None:
            self._thread.join()
            self._thread = None

    def _next_job(self):
        with self._cond:
            self._busy = False
            self._loading = None
            self._cond.notify_all()
            self._cond.wait_for(lambda: self._pending or self._stopping)
            if self._stopping:
                return None
            self._busy = True
            job = self._pending.pop(0)
            self._loading = job[0]
            return job

    def _run(self) -> None:
        while (job := self._next_job()) is not None:
            key, path, estimate = job
            signature = file_signature(path)
            if signature is None or self.cache.get(key, signature) is not None:
                continue
            if not self.cache.fits(estimate):
                with self._cond:
                    self._pending = []  # the budget is full: the rest would not fit either
                continue
            try:
                splats = self._load(path)
            except Exception:  # noqa: BLE001 - the synchronous load reports it when shown
                continue
            self.cache.put(key, splats, signature)
