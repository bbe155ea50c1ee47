"""Start bpy for the command line: factory settings, the add-on registered."""
from __future__ import annotations

import contextlib
import os
import re
import signal
import sys
import tempfile
import threading


def start(blend_path=None):
    """Import bpy, load blend_path (or an empty factory scene) and register Splatline.

    Returns the bpy module. Safe to call more than once in a process. Without bpy (a
    `pip install .` without the blender extra), one line says what to install. A .blend
    Blender cannot read is a SplatFormatError naming it, and nothing else is printed.
    """
    with _stops_held():
        return _start(blend_path)


@contextlib.contextmanager
def _stops_held():
    """SIGINT and SIGTERM wait while Blender starts: a KeyboardInterrupt raised inside bpy's
    import left a half-made Blender that crashed the process (SIGSEGV, measured on 5.0 and
    5.3 with SIGTERM 0.3-0.4 s after start). A stop asked for meanwhile is delivered to the
    command's own handler as soon as Blender is whole."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    asked = []
    held = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        old = signal.getsignal(sig)
        if callable(old):  # a Python handler, which would raise inside Blender's C code
            held[sig] = old
            signal.signal(sig, lambda signum, _frame: asked.append(signum))
    try:
        yield
    finally:
        for sig, old in held.items():
            signal.signal(sig, old)
        for signum in dict.fromkeys(asked):
            signal.raise_signal(signum)


def _start(blend_path):
    try:
        import bpy
    except ImportError as exc:
        if exc.name != "bpy":  # bpy is there but broken (a missing system library...)
            raise
        from . import UserError

        raise UserError(
            "this command needs Blender's Python module: pip install bpy (bpy 4.5 and 5.0 "
            "run on Python 3.11, bpy 5.1 and later on 3.13; this is Python "
            f"{sys.version_info[0]}.{sys.version_info[1]})"
        ) from None

    from .. import register

    # Register before loading: a .blend that uses the Splatline engine or properties
    # then loads without "engine not available" reports (registration survives loads).
    if not hasattr(bpy.types.Object, "splatline"):
        register()
    if blend_path is None:
        bpy.ops.wm.read_factory_settings(use_empty=True)
    else:
        _open(bpy, blend_path)
    return bpy


def save_blend(bpy, path) -> None:
    """Save the open scene as `path`, atomically as far as Blender allows: Blender writes
    `PATH@` whole, then renames it over `path`, so the old file stays whole until the
    rename. Backups are off for the save (Blender's `.blend1` step renames the old file
    away first, leaving a moment with no `path` at all, and a stray `.blend1` after).
    The output is claimed as every other writer's is (core/atomic.claim), so a `PATH@` left
    by a killed save is no other Splatline save's: it is removed first (Blender would
    truncate a regular one anyway, and would block on anything else). A failed save is one
    UserError naming the file."""
    from ..core import atomic
    from . import UserError

    path = os.path.abspath(os.fspath(path))
    folder, name = os.path.split(path)
    try:
        with atomic.claim(os.path.join(folder, f".{name}.splatline.lock"), "this .blend"):
            stale = path + "@"
            if os.path.lexists(stale) and not os.path.isdir(stale):
                os.unlink(stale)
            paths = bpy.context.preferences.filepaths
            versions, paths.save_version = paths.save_version, 0
            with atomic.replacing(path):  # interrupted: "wrote" when the save got it in place
                try:
                    result = bpy.ops.wm.save_as_mainfile(filepath=path, check_existing=False)
                finally:
                    paths.save_version = versions
                if "FINISHED" not in result:
                    raise UserError(f"{path}: Blender could not save the .blend")
    except atomic.Claimed as exc:
        raise UserError(f"{path}: {exc}") from None
    except RuntimeError as exc:  # Blender reports a failed save as an error report
        raise UserError(f"{path}: cannot save: {' '.join(str(exc).split())}") from None


def _open(bpy, path) -> None:
    """open_mainfile, whose failure is one line: Blender prints its own report of a file it
    cannot read ("Error: File format is not supported in file ...") on stdout before raising
    it, so what it prints is held back and shown only when the file opened."""
    from ..core.errors import SplatFormatError

    try:
        with _stdout_dropped_on_error():
            bpy.ops.wm.open_mainfile(filepath=str(path))
    except RuntimeError as exc:
        raise SplatFormatError(path, f"cannot open: {_open_reason(exc)}") from None


def _open_reason(exc) -> str:
    """Blender's reason for not opening a .blend, without its 'Error:' prefix and its
    repetitions of the path (the caller names the file once)."""
    text = " ".join(str(exc).split()).removeprefix("Error:").strip()
    text = re.sub(r'Loading "[^"]*" failed: ', "", text)
    text = re.sub(r"Failed to read blend file '[^']*': ", "", text)
    text = re.sub(r' in file "[^"]*"', "", text)
    return text or type(exc).__name__


@contextlib.contextmanager
def _stdout_dropped_on_error():
    """File descriptor 1 sent to a temporary file for the block (Blender prints from C, so
    sys.stdout alone would not catch it), then written out, unless the block raised.
    Where C's stdio cannot be flushed from here (no process-wide libc), nothing is held."""
    fflush, tmp = _c_fflush(), None
    if fflush is not None:
        try:
            tmp = tempfile.TemporaryFile()
            saved = os.dup(1)
        except OSError:  # nowhere for a temporary file, or no stdout: hold nothing back
            if tmp is not None:
                tmp.close()
            tmp = None
    if tmp is None:
        yield
        return
    sys.stdout.flush()
    fflush(None)
    failed = False
    with tmp:
        os.dup2(tmp.fileno(), 1)
        try:
            yield
        except BaseException:
            failed = True
            raise
        finally:
            fflush(None)
            os.dup2(saved, 1)
            os.close(saved)
            if not failed:
                tmp.seek(0)
                data = tmp.read()
                while data:
                    data = data[os.write(1, data):]


def _c_fflush():
    try:
        import ctypes

        return ctypes.CDLL(None).fflush
    except (OSError, TypeError, AttributeError):  # Windows: no process-wide libc to load
        return None
