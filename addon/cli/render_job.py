"""One animation render driven from the command line (`render` and `demo` both run it):
Blender's own pipeline (bpy.ops.render.render, what `blender -b -a` runs), a line per
finished frame from Blender's render handlers, and Ctrl+C. Blender's GPU-context probe
lines (`EGL Error ... EGL_BAD_MATCH`) are kept off stderr (stderr_filter.py).

The output folder's frames are claimed while the job runs (`_claimed`): a second render
of overlapping frames into it stops with one line. SIGTERM is handled as SIGINT.

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
and the next render into the folder removes those of dead processes); movies (FFmpeg) are one growing file Blender writes itself, and stereo views (multiview)
and the no-overwrite / placeholder options, whose checks Blender makes on the final name,
keep Blender's own direct write. Blender's own "Saved:" line would name the temporary: the
job's stdout passes through stderr_filter.final_frame_names, which prints the final name.
"""
from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import time

from . import UserError
from ..core import atomic, stop
from .stderr_filter import final_frame_names, without_egl_probe_lines


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
    atomic.remove_dead_temporaries(folder, _FRAME_TEMPORARY)


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
    """First SIGINT or SIGTERM: ask the engine to stop after saving nothing more (the job
    then ends as after Ctrl+C: finished frames kept, temporaries removed, exit 130).
    A second SIGINT: Python's default (KeyboardInterrupt); a second SIGTERM: the
    temporaries and the claim removed, then the process ends by SIGTERM."""

    def __init__(self):
        self._old = {}

    def _handle(self, signum, frame):
        if stop.stop_requested() and signum == signal.SIGTERM:
            atomic.remove_temporaries()
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            os.kill(os.getpid(), signal.SIGTERM)
            return
        stop.request_stop()
        name = "Ctrl+C" if signum == signal.SIGINT else "SIGTERM"
        print(f"stopping ({name}): finished frames are kept (Ctrl+C again to quit now)", flush=True)
        signal.signal(signal.SIGINT, signal.default_int_handler)

    def __enter__(self):
        stop.clear_stop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            self._old[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc):
        for sig, old in self._old.items():
            signal.signal(sig, old)


def render_animation(bpy, scene, total: int, label: str) -> tuple[list[float], bool]:
    """Render the scene's frame range: (seconds per finished frame, whether Ctrl+C stopped
    it). A render error other than the stop is a UserError starting with `label`."""
    with _claimed(scene), TemporaryFrames(bpy, scene) as frames, \
            Progress(bpy, total, frames) as progress, _StopOnSigint(), without_egl_probe_lines(), \
            final_frame_names():
        try:
            bpy.ops.render.render(animation=True, scene=scene.name)
        except RuntimeError as exc:
            if not stop.stop_requested():
                raise UserError(f"{label}: {one_line(exc)}") from None
    return progress.times, stop.stop_requested()


_RENDER_LOCK = re.compile(r"^\.splatline-render\.(\d+)\.lock$")


def _overlap(a: range, b: range) -> bool:
    if not a or not b or a[-1] < b[0] or b[-1] < a[0]:
        return False
    small, big = (a, b) if len(a) <= len(b) else (b, a)
    return any(f in big for f in small)


@contextlib.contextmanager
def _claimed(scene):
    """The output folder's frames are claimed for the job: each render holds an flock on its
    own `.splatline-render.PID.lock` there (it appears already locked, by a rename), which
    names its file pattern and frames. A render whose frames overlap a running one's (same
    pattern) stops with one line; disjoint ranges (a farm's split) run side by side. A lock
    file nobody holds any more (kill -9) is removed. No fcntl (Windows): nothing claimed."""
    try:
        import fcntl
    except ImportError:
        yield
        return
    folder, pattern = os.path.split(scene.render.frame_path(frame=scene.frame_start))
    pattern = os.path.basename(scene.render.filepath)
    mine = range(scene.frame_start, scene.frame_end + 1, max(1, scene.frame_step))
    lock = os.path.join(folder, f".splatline-render.{os.getpid()}.lock")
    try:
        tmp = atomic.temporary_name(lock)
        fd = os.open(tmp, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o666)
    except OSError:  # no such folder yet, or unwritable: Blender's write says what is wrong
        yield
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        os.write(fd, json.dumps({"pid": os.getpid(), "pattern": pattern,
                                 "frames": [mine.start, mine.stop, mine.step]}).encode())
        atomic.register_temporary(lock)
        os.replace(tmp, lock)
        for name in sorted(os.listdir(folder)):
            m = _RENDER_LOCK.match(name)
            if m is None or int(m.group(1)) == os.getpid():
                continue
            other = _holder(fcntl, os.path.join(folder, name))
            if other is not None and other.get("pattern") == pattern and \
                    _overlap(mine, range(*other.get("frames", (0, 0, 1)))):
                r = range(*other["frames"])
                raise UserError(f"the output folder {folder} is being written by another Splatline "
                                f"run (process {m.group(1)}, frames {r.start}-{r[-1]}); wait for it "
                                "to end or choose another --out")
        yield
    finally:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        atomic.forget_temporary(lock, remove=True)
        os.close(fd)


def _holder(fcntl, path):
    """The claim in a lock file that a live process holds; None after removing a dead one's."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            try:
                return json.loads(os.pread(fd, 4096, 0))
            except (OSError, ValueError):
                return {}
        with contextlib.suppress(OSError):
            os.unlink(path)  # nobody holds it: its render is gone
        return None
    finally:
        os.close(fd)


def one_line(exc) -> str:
    text = " ".join(str(exc).split())
    return text.removeprefix("Error: ") or type(exc).__name__
