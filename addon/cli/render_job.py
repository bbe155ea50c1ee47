"""One animation render driven from the command line (`render` and `demo` both run it):
Blender's own pipeline (bpy.ops.render.render, what `blender -b -a` runs), a line per
finished frame from Blender's render handlers, and Ctrl+C.

Ctrl+C (SIGINT): the first asks the engine to stop (core/stop.py) at the frame being
rendered, which Blender then does not write; every finished frame stays whole on disk.
A second Ctrl+C stops at once.
"""
from __future__ import annotations

import signal
import time

from . import UserError
from ..core import stop


class Progress:
    """Per-frame lines from Blender's render handlers (added for one render, then removed)."""

    def __init__(self, bpy, total: int):
        self.bpy, self.total, self.times, self._t0 = bpy, total, [], None
        self._handlers = (("render_pre", self.pre), ("render_write", self.written))

    def pre(self, scene, *_):
        self._t0 = time.perf_counter()

    def written(self, scene, *_):
        seconds = time.perf_counter() - (self._t0 or time.perf_counter())
        self.times.append(seconds)
        frame = scene.frame_current
        path = scene.render.frame_path(frame=frame)
        # milliseconds: small frames take a few (two decimals printed some as 0.00 s)
        print(f"frame {frame} ({len(self.times)}/{self.total})  {seconds:.3f} s  {path}", flush=True)

    def __enter__(self):
        for name, fn in self._handlers:
            getattr(self.bpy.app.handlers, name).append(fn)
        return self

    def __exit__(self, *exc):
        for name, fn in self._handlers:
            handlers = getattr(self.bpy.app.handlers, name)
            if fn in handlers:
                handlers.remove(fn)


class _StopOnSigint:
    """First SIGINT: ask the engine to stop after saving nothing more; second: default."""

    def __init__(self):
        self._old = None

    def _handle(self, signum, frame):
        stop.request_stop()
        print("stopping: finished frames are kept (Ctrl+C again to quit now)", flush=True)
        signal.signal(signal.SIGINT, signal.default_int_handler)

    def __enter__(self):
        stop.clear_stop()
        self._old = signal.signal(signal.SIGINT, self._handle)
        return self

    def __exit__(self, *exc):
        signal.signal(signal.SIGINT, self._old)


def render_animation(bpy, scene, total: int, label: str) -> tuple[list[float], bool]:
    """Render the scene's frame range: (seconds per finished frame, whether Ctrl+C stopped
    it). A render error other than the stop is a UserError starting with `label`."""
    with Progress(bpy, total) as progress, _StopOnSigint():
        try:
            bpy.ops.render.render(animation=True, scene=scene.name)
        except RuntimeError as exc:
            if not stop.stop_requested():
                raise UserError(f"{label}: {one_line(exc)}") from None
    return progress.times, stop.stop_requested()


def one_line(exc) -> str:
    text = " ".join(str(exc).split())
    return text.removeprefix("Error: ") or type(exc).__name__
