"""Stopping a render job from outside Blender's UI: SIGINT (Ctrl+C) in headless runs.

Blender's UI has Esc (RenderEngine.test_break). A Python process driving bpy has only
Python's default SIGINT handler, whose KeyboardInterrupt surfaces in whatever Python
code runs next: often a handler that Blender calls and whose exception it prints and
drops, so the render goes on. Instead, while a job runs, SIGINT sets a flag that the
engine checks between stages; it then cancels the frame in progress (Blender writes
no file for it) and ends the job. Finished frames stay on disk, whole.

Only Python's own default handler is replaced, and only for the job: a program that
installed its own handler (the command line does) keeps it, and so does Blender's
executable, whose C handler already breaks renders through test_break.
"""
from __future__ import annotations

import signal
import sys
import threading

_STOP = threading.Event()
# A SIGTERM to the command line: it outlasts the jobs' own clears. Its KeyboardInterrupt can
# be swallowed where Blender calls Python (a handler run during an import), and a 10M-splat
# render then went on for 19 s; the flag still stops the job at its first check.
_TERMINATED = threading.Event()


def request_stop():
    _STOP.set()


def clear_stop():
    if not _TERMINATED.is_set():
        _STOP.clear()


def terminate():
    """The command was asked to end (SIGTERM): every job it starts stops at once."""
    _TERMINATED.set()
    _STOP.set()


def forget_termination():
    """A new command in this process (tests, scripts) starts without the last one's SIGTERM."""
    _TERMINATED.clear()
    _STOP.clear()


def stop_requested() -> bool:
    return _STOP.is_set()


class Stopped(Exception):
    """Raised by check() where a long stage gives way to a requested stop."""


def check() -> None:
    """Raise Stopped when a stop was requested: called between the parts of a long stage (a
    frame's GL tiles and batches, the reads of a large PointCloud), so a stop takes effect
    within a part, not at the end of the frame."""
    if _STOP.is_set():
        raise Stopped()


def _on_sigint(signum, frame):
    request_stop()
    print("stopping the render: finished frames are kept (Ctrl+C again to quit now)",
          file=sys.stderr, flush=True)
    signal.signal(signal.SIGINT, signal.default_int_handler)


class SigintGuard:
    """Swaps Python's default SIGINT handler for _on_sigint from job start to job end."""

    def __init__(self):
        self.installed = False

    def job_started(self, background: bool):
        clear_stop()
        if not background or threading.current_thread() is not threading.main_thread():
            return
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            signal.signal(signal.SIGINT, _on_sigint)
            self.installed = True

    def job_ended(self):
        if self.installed and threading.current_thread() is threading.main_thread():
            if signal.getsignal(signal.SIGINT) is _on_sigint:
                signal.signal(signal.SIGINT, signal.default_int_handler)
            self.installed = False
