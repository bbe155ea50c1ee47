"""One animation render driven from the command line (`render` and `demo` both run it):
Blender's own pipeline (bpy.ops.render.render, what `blender -b -a` runs), a line per
finished frame from Blender's render handlers, and Ctrl+C.

Ctrl+C (SIGINT): the first asks the engine to stop (core/stop.py) at the frame being
rendered, which Blender then does not write; every finished frame stays whole on disk.
A second Ctrl+C stops at once.

Frames reach their final names only by a rename (`TemporaryFrames`). Blender writes each
frame file itself, inside render.render, to the path its filepath pattern gives; the job
points that pattern at a hidden temporary name in the same folder (`.frame_0001.PID.frametmp.png`
for `frame_####`), and the render_write handler, which Blender calls once the file is
written and closed, fsyncs it and renames it to the name the user's pattern gives. So a
killed or failed render never leaves a cut file under a final name, and never touches an
older frame of that name before the new one is whole. What remains: a kill -9 during
Blender's write leaves that hidden `.NAME.PID.frametmp.EXT` (a catchable signal removes it,
and the next render into the folder removes those of dead processes); Blender's own
"Saved:" line names the temporary; movies (FFmpeg) are one growing file Blender writes itself, and stereo views (multiview)
and the no-overwrite / placeholder options, whose checks Blender makes on the final name,
keep Blender's own direct write.
"""
from __future__ import annotations

import contextlib
import os
import re
import signal
import time

from . import UserError
from ..core import atomic, stop


class Progress:
    """Per-frame lines from Blender's render handlers (added for one render, then removed)."""

    def __init__(self, bpy, total: int, frames: TemporaryFrames | None = None):
        self.bpy, self.total, self.times, self._t0 = bpy, total, [], None
        self.frames = frames
        self._handlers = (("render_pre", self.pre), ("render_write", self.written))

    def pre(self, scene, *_):
        self._t0 = time.perf_counter()
        if self.frames is not None:
            self.frames.pre(scene)

    def written(self, scene, *_):
        seconds = time.perf_counter() - (self._t0 or time.perf_counter())
        self.times.append(seconds)
        frame = scene.frame_current
        path = self.frames.written(scene) if self.frames is not None else \
            scene.render.frame_path(frame=frame)
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


_FRAME_TEMPORARY = re.compile(r"^\..+\.(\d+)\.frametmp(\.[A-Za-z0-9]+)?$")


def remove_dead_frames(folder: str) -> None:
    """Remove the hidden frame temporaries a killed render (kill -9) left in folder: those
    whose process is gone."""
    try:
        names = os.listdir(folder)
    except OSError:
        return
    for name in names:
        m = _FRAME_TEMPORARY.match(name)
        if m is None or int(m.group(1)) == os.getpid():
            continue
        try:
            os.kill(int(m.group(1)), 0)
            continue  # that render still runs
        except ProcessLookupError:
            pass
        except (PermissionError, OverflowError, OSError):
            continue
        with contextlib.suppress(OSError):
            os.unlink(os.path.join(folder, name))


class TemporaryFrames:
    """Points the scene's output at hidden temporary names for the job, and renames each
    frame to its final name once Blender has written it (see the module docstring)."""

    def __init__(self, bpy, scene):
        self.bpy, self.scene = bpy, scene
        self.original = self.marker = None
        self.pending: set[str] = set()

    @staticmethod
    def applies(scene) -> bool:
        r = scene.render
        movie = getattr(r, "is_movie_format", False) or r.image_settings.file_format == "FFMPEG"
        return not (movie or r.use_multiview or r.use_placeholder or not r.use_overwrite)

    def final_path(self, frame: int) -> str:
        path = self.scene.render.frame_path(frame=frame)
        if self.marker is None:
            return path
        folder, name = os.path.split(path)
        return os.path.join(folder, name[1:].replace(self.marker, "", 1))

    def pre(self, scene, *_):
        if self.marker is not None and scene == self.scene:
            path = scene.render.frame_path(frame=scene.frame_current)
            self.pending.add(path)
            atomic.register_temporary(path)

    def written(self, scene, *_):
        """Rename the frame Blender has just written to its final name; its final path."""
        frame = scene.frame_current
        if self.marker is None or scene != self.scene:
            return scene.render.frame_path(frame=frame)
        tmp, final = scene.render.frame_path(frame=frame), self.final_path(frame)
        atomic.sync_file(tmp)
        os.replace(tmp, final)
        self.pending.discard(tmp)
        atomic.forget_temporary(tmp)
        return final

    def __enter__(self):
        if self.applies(self.scene):
            self.original = self.scene.render.filepath
            self.marker = f".{os.getpid()}.frametmp"
            folder, name = os.path.split(self.original)
            self.scene.render.filepath = os.path.join(folder, f".{name}{self.marker}")
            remove_dead_frames(os.path.dirname(self.scene.render.frame_path(frame=self.scene.frame_start)))
        return self

    def __exit__(self, *exc):
        if self.original is not None:
            self.scene.render.filepath = self.original
        for path in self.pending:  # a frame stopped, failed or interrupted mid-write
            atomic.forget_temporary(path, remove=True)
        self.pending.clear()


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
    with TemporaryFrames(bpy, scene) as frames, Progress(bpy, total, frames) as progress, \
            _StopOnSigint():
        try:
            bpy.ops.render.render(animation=True, scene=scene.name)
        except RuntimeError as exc:
            if not stop.stop_requested():
                raise UserError(f"{label}: {one_line(exc)}") from None
    return progress.times, stop.stop_requested()


def one_line(exc) -> str:
    text = " ".join(str(exc).split())
    return text.removeprefix("Error: ") or type(exc).__name__
