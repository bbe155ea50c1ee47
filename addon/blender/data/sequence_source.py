"""The sequence source: the splats a sequence object shows at the depsgraph's frame, from
disk through a cache (its row of the source table, sources.py, is `ROW`).

`sequence_frame(obj_eval, depsgraph)` gives the frame's splats and cache key, or None for an
object that is not a sequence. Everything here is owned by one SequenceRuntime
created on first use and torn down by `shutdown()` (this module's unregister), which also
joins the read-ahead thread; nothing is stored on bpy. This module also owns the load_post
handler that lets go of the previous file's objects.

Cached frames are shared and read-only (see _load). What is shown is decided synchronously (the mapped frame, or the previous available one when
its file is missing or unreadable), so it never depends on the read-ahead thread's timing.
"""
from __future__ import annotations

import logging
import os
from dataclasses import dataclass

import bpy

from ...core import sequence as core_sequence
from ...core.errors import SplatFormatError
from ...core.formats import read
from ...core.splats import ARRAYS, SplatSet
from ..registration import app_handlers
from .source_kind import SourceFrame, SplatSource

log = logging.getLogger("splatline.sequence")
MB = 1 << 20


@dataclass
class SequenceFrame:
    splats: SplatSet
    index: int          # the frame shown (differs from `wanted` when holding)
    wanted: int         # the frame the time maps to
    path: str
    key: tuple          # (resolved file path, index, file signature): changes with the data


def _load(path) -> SplatSet:
    """Decode a frame. Its arrays are shared by the cache and every item built from them,
    so they are made read-only: an effect writing in place fails loudly instead of
    corrupting the cached frame for the next evaluation."""
    splats = read(path)
    for name in ARRAYS:
        getattr(splats, name).setflags(write=False)
    return splats


class SequenceRuntime:
    def __init__(self, budget_bytes: int = 512 * MB):
        self.cache = core_sequence.FrameCache(budget_bytes)
        self.read_ahead = core_sequence.ReadAhead(self.cache, _load)
        self.reports: dict = {}      # object name -> last problem message ("" = fine)
        self._reported: set = set()  # (path, reason) already logged once

    def frame(self, owner: str, pattern, time: float, start: float, speed: float, offset: float,
              mode: str, budget_bytes: int, read_ahead: int) -> SequenceFrame:
        self.cache.set_budget(budget_bytes)
        wanted = core_sequence.frame_index(time, pattern.count, start, speed, offset, mode)
        problems = []
        for index in _candidates(wanted, pattern.count):
            path = os.path.abspath(pattern.path(index))
            got = self._get(owner, path, index, problems)
            if got is not None:
                splats, key = got
                self.cache.pin(owner, key[:2])
                self._report(owner, problems, index)
                self._schedule(pattern, time, (start, speed, offset, mode), read_ahead, splats)
                return SequenceFrame(splats, index, wanted, path, key)
        self._report(owner, problems, None)
        self.cache.unpin(owner)
        return SequenceFrame(SplatSet.empty(), wanted, wanted, "", ("<none>", wanted, None))

    def _get(self, owner, path, index, problems):
        signature = core_sequence.file_signature(path)
        if signature is None:
            problems.append((path, "missing"))
            return None
        key = (path, index)
        splats = self.cache.get(key, signature)
        if splats is None:
            self.read_ahead.wait_if_loading(key)
            splats = self.cache.get(key, signature)
        if splats is None:
            try:
                splats = _load(path)
            except SplatFormatError as exc:
                problems.append((path, exc.reason))
                return None
            self.cache.put(key, splats, signature, owner=owner)
        return splats, key + (signature,)

    def _report(self, owner, problems, shown) -> None:
        if not problems:
            self.reports[owner] = ""
            return
        path, reason = problems[0]
        held = "nothing to show" if shown is None else f"holding frame {shown}"
        message = f"{os.path.basename(path)}: {reason}; {held}"
        self.reports[owner] = message
        # once per file and reason, not once per redraw; only the wanted frame's problem
        # (a whole missing folder would otherwise log every file it searched)
        if problems[0] not in self._reported:
            self._reported.add(problems[0])
            log.warning("Splatline sequence %r: %s: %s; %s", owner, path, reason, held)

    def _schedule(self, pattern, time, mapping, count, current: SplatSet) -> None:
        if count <= 0:
            return
        estimate = core_sequence.splats_nbytes(current)
        jobs, seen = [], set()
        for step in range(1, count + 1):
            index = core_sequence.frame_index(time + step, pattern.count, *mapping)
            path = os.path.abspath(pattern.path(index))
            if index not in seen and (path, index) not in self.cache:
                seen.add(index)
                jobs.append(((path, index), path, estimate))
        if jobs:
            self.read_ahead.request(jobs)

    def forget_objects(self) -> None:
        """A new file: no object's current frame needs keeping any more (frames stay cached
        within the budget, as they are keyed by file)."""
        self.cache.unpin_all()
        self.reports.clear()
        self._reported.clear()

    def shutdown(self) -> None:
        self.read_ahead.stop()
        self.cache.clear()


def _candidates(wanted: int, count: int):
    """The wanted frame, then earlier ones (hold the previous), then later ones."""
    yield from range(wanted, -1, -1)
    yield from range(wanted + 1, count)


_runtime: SequenceRuntime | None = None


def runtime() -> SequenceRuntime:
    global _runtime
    if _runtime is None:
        _runtime = SequenceRuntime()
    return _runtime


def shutdown() -> None:
    """Stop and join the read-ahead thread and drop every cached frame."""
    global _runtime
    if _runtime is not None:
        _runtime.shutdown()
        _runtime = None


def forget_objects() -> None:
    if _runtime is not None:
        _runtime.forget_objects()


def resolved_directory(obj, settings) -> str:
    return bpy.path.abspath(settings.directory, library=obj.library)


def plays_sequence(obj) -> bool:
    """The object shows a splat sequence. Read through getattr: data/ does not import
    props/, where the sequence settings live."""
    sequence = getattr(getattr(obj, "splatline", None), "sequence", None)
    return bool(getattr(sequence, "enabled", False))


def sequence_frame(obj_eval, depsgraph) -> SequenceFrame | None:
    """The frame a sequence object shows at the depsgraph's time; None if not a sequence."""
    settings = getattr(getattr(obj_eval, "splatline", None), "sequence", None)
    if settings is None or not settings.enabled:
        return None
    pattern = settings.pattern(resolved_directory(obj_eval, settings))
    time = depsgraph.scene_eval.frame_float
    owner = (obj_eval.original or obj_eval).name_full  # unique, also for linked objects
    return runtime().frame(owner, pattern, time, settings.start_frame, settings.speed,
                           settings.frame_offset, settings.loop_mode,
                           settings.cache_budget_mb * MB, settings.read_ahead)


def report_for(obj) -> str:
    """The object's last sequence problem ('' when its frames load fine), for the UI."""
    return "" if _runtime is None else _runtime.reports.get(obj.name_full, "")


def _source_frame(obj_eval, depsgraph) -> SourceFrame:
    frame = sequence_frame(obj_eval, depsgraph)
    return SourceFrame(frame.splats, ("sequence", obj_eval.original.name_full) + tuple(frame.key))


# Each frame is a file of its own: splats change with the frame, but each sits still in it.
ROW = SplatSource("SEQUENCE", "Splat Sequence", plays_sequence, _source_frame,
                  depends_on_time=True, moves_splats=False)


@bpy.app.handlers.persistent
def _on_load(*_args):
    forget_objects()


register, unregister = app_handlers(((bpy.app.handlers.load_post, _on_load),), on_unregister=shutdown)
