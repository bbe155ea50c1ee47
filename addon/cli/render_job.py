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
written and closed, reads it back (core/whole_file: Blender's PNG writer closes a cut file
on a full disk and says "Saved:"), fsyncs it and renames it to the name the user's pattern
gives; a frame that is not whole stops the job with one line. So a killed or failed render
never leaves a cut file under a final name, and never touches an older frame of that name
before the new one is whole. A movie (FFmpeg) is one file under such a hidden name too,
renamed once Blender has closed it: whole, to its name; stopped, to the name of the frames
it holds. What remains: a kill -9 during Blender's write leaves that hidden
`.NAME.PID.frametmp.EXT` (a catchable signal removes it, and the next render into the folder
removes those of dead processes); Blender's own "Saved:" line would name the temporary: the
job's stdout passes through stderr_filter.final_frame_names, which prints the final name; stereo
views (multiview) and the no-overwrite / placeholder options, whose checks Blender makes on
the final name, keep Blender's own direct write.
"""
from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import time

from . import UserError
from ..core import atomic, stop, whole_file
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
        frame = scene.frame_current
        path = self.frames.written(scene) if self.frames is not None else \
            scene.render.frame_path(frame=frame)
        if path is None:  # not written whole: the job stops with the frame's line
            return
        self.times.append(seconds)
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
    frame to its final name once Blender has written it and it reads back whole (see the
    module docstring). A frame that does not is removed, recorded in `failure`, and the job
    is stopped. A movie is renamed once the job ends: whole to its name, interrupted to the
    name of the frames it holds (`finish_movie`)."""

    def __init__(self, bpy, scene):
        self.bpy, self.scene = bpy, scene
        self.original = self.marker = None
        self.pending: set[str] = set()
        self.movie = is_movie(scene)
        self.done: list[int] = []  # the frames written (a movie's: appended to it)
        self.failure: str | None = None

    @staticmethod
    def applies(scene) -> bool:
        r = scene.render
        return not (r.use_multiview or r.use_placeholder or not r.use_overwrite)

    def final_path(self, frame: int) -> str:
        return self._unmarked(self.scene.render.frame_path(frame=frame))

    def _unmarked(self, path: str) -> str:
        if self.marker is None:
            return path
        folder, name = os.path.split(path)
        return os.path.join(folder, name[1:].replace(self.marker, "", 1))

    def pre(self, scene, *_):
        if self.marker is not None and scene == self.scene:
            path = scene.render.frame_path(frame=scene.frame_current)
            if path not in self.pending:
                self.pending.add(path)
                atomic.register_temporary(path)

    def written(self, scene, *_):
        """Rename the frame Blender has just written to its final name, once it reads back
        whole; its final path (None when it did not: the job is then stopped)."""
        frame = scene.frame_current
        if self.marker is None or scene != self.scene:
            if scene == self.scene:
                self.done.append(frame)
            return scene.render.frame_path(frame=frame)
        tmp, final = scene.render.frame_path(frame=frame), self.final_path(frame)
        if self.movie:  # one file for the job: renamed in finish_movie
            self.done.append(frame)
            return final
        what = whole_file.problem(tmp)
        try:
            if what is None:
                atomic.sync_file(tmp)
                with atomic.replacing(final):
                    os.replace(tmp, final)
        except OSError as exc:
            what = exc.strerror or str(exc)
        if what is not None:
            self._fail(f"frame {frame} not written to {final}: "
                       f"{whole_file.reason(os.path.dirname(final), what)}")
            return None
        self.pending.discard(tmp)
        atomic.forget_temporary(tmp)
        self.done.append(frame)
        return final

    def _fail(self, line: str) -> None:
        if self.failure is None:
            self.failure = line
        stop.request_stop()  # the engine cancels the next frame: Blender writes no more

    def failed_line(self, error: str) -> str:
        """The line for a job Blender's writer failed: its error, why, and what is on disk."""
        folder = os.path.dirname(self.final_path(self.scene.frame_start))
        line = whole_file.reason(folder, error)
        kept = (f"; the movie {self.final_path(self.scene.frame_start)} is as it was" if self.movie
                else "; earlier frames are whole, this one and later ones as they were")
        return line + kept if self.marker is not None else line

    def finish_movie(self, stopped: bool, label: str) -> str | None:
        """Rename the closed movie: whole, to its name; stopped, to the name of the frames it
        holds (frame_0001-0005.mp4 of 1-6); removed when it holds none or is not whole. The
        path it now has, or None."""
        if not self.movie:
            return None
        if self.marker is None:  # Blender's own direct write (stereo, placeholders)
            return self.scene.render.frame_path(frame=self.scene.frame_start) if self.done else None
        tmp = self.scene.render.frame_path(frame=self.scene.frame_start)
        final = self._unmarked(tmp)
        what = whole_file.problem(tmp) if self.done else "no frame finished"
        if not stopped and what is not None:
            self._remove(tmp)
            raise UserError(f"{label}: movie not written to {final}: "
                            f"{whole_file.reason(os.path.dirname(final), what)}; "
                            "an earlier movie of that name is as it was")
        if stopped:
            final = self._held_name(self.done[-1]) if what is None else None
            if final is None or os.path.lexists(final):
                self._remove(tmp)
                return None
        with atomic.replacing(final):
            os.replace(tmp, final)
        self.pending.discard(tmp)
        atomic.forget_temporary(tmp)
        return final

    def _held_name(self, last: int) -> str:
        """The movie's name for the frames start..last (Blender's naming from the range)."""
        end = self.scene.frame_end
        self.scene.frame_end = last
        try:
            return self._unmarked(self.scene.render.frame_path(frame=self.scene.frame_start))
        finally:
            self.scene.frame_end = end

    def _remove(self, tmp: str) -> None:
        self.pending.discard(tmp)
        atomic.forget_temporary(tmp, remove=True)

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


def is_movie(scene) -> bool:
    r = scene.render
    return bool(getattr(r, "is_movie_format", False)) or r.image_settings.file_format == "FFMPEG"


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
        stop.clear_stop()  # the stop was this job's: later reads (core/stop.check) go on


def render_animation(bpy, scene, total: int, label: str) -> tuple[list[float], bool, str | None]:
    """Render the scene's frame range: (seconds per finished frame, whether Ctrl+C stopped
    it, the movie's path where one was written). A render error other than the stop, or a
    frame or movie that did not reach the disk whole, is a UserError starting with `label`."""
    with _claimed(scene), TemporaryFrames(bpy, scene) as frames, \
            Progress(bpy, total, frames) as progress, _StopOnSigint(), without_egl_probe_lines(), \
            final_frame_names():
        error = None
        try:
            bpy.ops.render.render(animation=True, scene=scene.name)
        except RuntimeError as exc:
            error = exc
        if frames.failure is not None:
            raise UserError(f"{label}: {frames.failure}")
        if error is not None and not stop.stop_requested():
            raise UserError(f"{label}: {frames.failed_line(one_line(error))}") from None
        stopped = stop.stop_requested()
        movie = frames.finish_movie(stopped, label)
    return progress.times, stopped, movie


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
        try:
            os.write(fd, json.dumps({"pid": os.getpid(), "pattern": pattern,
                                     "frames": [mine.start, mine.stop, mine.step]}).encode())
        except OSError as exc:  # a full disk: the error names the folder (nothing written yet)
            exc.filename = folder
            raise
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
