"""Atomic file writes: the one helper behind every writer (formats, SOG bundles, frames).

A file is written under a temporary name in its own folder (`.NAME.PID.HEX.tmp`: same
file system, so the rename cannot copy), flushed and fsync'd, then renamed over the target
with os.replace. A reader, or a process killed at any point, sees the old file or the new
one, never a mix or a cut file.

Temporaries are removed when the write fails (any exception, KeyboardInterrupt included)
and when the process ends by a signal it can catch: every live temporary is registered
here, and while a write runs in the main thread of a process whose SIGTERM is still the
default, SIGTERM removes them and then terminates the process by SIGTERM as before
(the command line handles SIGTERM as Ctrl+C instead, addon/__main__.py: the
KeyboardInterrupt removes them as any exception does). kill -9
cannot be caught: it may leave a `.NAME.PID.HEX.tmp` beside the target, never a damaged
target, and the next write to that target removes it once its writer is gone.

Several files (an unbundled SOG: its images and meta.json) go through `write_group`: every
file is first written whole as a temporary beside its target, then each is renamed in,
meta.json last. The renames take microseconds; only in that window could a reader (or a
kill -9) see some new images beside the old meta.json. A failure before the renames
leaves every old file as it was.
"""
from __future__ import annotations

import contextlib
import os
import re
import secrets
import shutil
import signal
import stat
import tempfile
import threading

import numpy as np

_LIVE: set[str] = set()
_LOCK = threading.Lock()
_ATTEMPTS: list[tuple[str, tuple | None]] = []  # outputs this process set out to replace


def _identity(path):
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_dev, st.st_ino, st.st_mtime_ns, st.st_size


@contextlib.contextmanager
def replacing(path):
    """The block may put path in place (a rename, Blender's save). Its identity before is
    kept, so an interrupted command can say afterwards whether it was replaced (written()),
    however late in the block the signal came: nothing here delays the interrupt."""
    _ATTEMPTS.append((os.fspath(path), _identity(path)))
    yield


def forget_attempts() -> None:
    """A new command: what earlier ones replaced is not its to report."""
    _ATTEMPTS.clear()


def written() -> list[str]:
    """The outputs this process replaced or made, as the disk shows them now."""
    out = []
    for path, before in _ATTEMPTS:
        now = _identity(path)
        if now is not None and now != before and path not in out:
            out.append(path)
    return out


def temporary_name(target: str) -> str:
    folder, name = os.path.split(target)
    return os.path.join(folder, f".{name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")


def remove_temporaries() -> None:
    """Remove every temporary this process still has (a signal handler's clean-up)."""
    with _LOCK:
        live = list(_LIVE)
        _LIVE.clear()
    for path in live:
        _remove(path)


def _remove(path: str) -> None:
    with contextlib.suppress(OSError):
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path, ignore_errors=True)
        else:
            os.unlink(path)


def register_temporary(path: str) -> None:
    """A temporary another writer makes (Blender's frame writer): removed as ours are."""
    _register(os.path.abspath(path))


def forget_temporary(path: str, remove: bool = False) -> None:
    _forget(os.path.abspath(path), remove)


def sync_file(path: str) -> None:
    """fsync a file written by someone else, before it is renamed into place."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _register(path: str) -> None:
    with _LOCK:
        _LIVE.add(path)


def _forget(path: str, remove: bool) -> None:
    with _LOCK:
        _LIVE.discard(path)
    if remove:
        _remove(path)


def _on_sigterm(signum, frame):
    remove_temporaries()
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    os.kill(os.getpid(), signal.SIGTERM)  # end as SIGTERM would have, without the temporaries


@contextlib.contextmanager
def sigterm_cleans_up():
    """While the block runs, SIGTERM removes the live temporaries before ending the process:
    only in the main thread, and only over the default handler (a program's own stays)."""
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        yield
        return
    signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        yield
    finally:
        if signal.getsignal(signal.SIGTERM) is _on_sigterm:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)


@contextlib.contextmanager
def temporary_folder(prefix: str = "splatline-"):
    """A private scratch folder (tempfile.mkdtemp), removed at the end of the block, on any
    exception and, inside sigterm_cleans_up, on SIGTERM."""
    folder = tempfile.mkdtemp(prefix=prefix)
    _register(folder)
    try:
        yield folder
    finally:
        _forget(folder, remove=True)


def _write_parts(f, parts) -> None:
    for part in parts:
        f.write(part.view(np.uint8).data if isinstance(part, np.ndarray) else part)


def _stat(target: str):
    try:
        return os.stat(target)
    except FileNotFoundError:
        return None


_FILE_TEMPORARY = r"^\.{name}\.(\d+)\.[0-9a-f]+\.tmp$"


def _process_gone(pid: int) -> bool:
    """Whether no process has this id (one we may not signal, or an odd id, counts as live)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except (PermissionError, OverflowError, OSError):
        return False
    return False


def remove_dead_temporaries(folder: str, pattern) -> None:
    """Remove the temporaries a process killed by kill -9 left in folder: names matching
    pattern (a regex whose group 1 is the writer's process id) whose process is gone. A live
    writer's, ours included, stay."""
    pattern = re.compile(pattern) if isinstance(pattern, str) else pattern
    try:
        names = os.listdir(folder or ".")
    except OSError:
        return
    for name in names:
        m = pattern.match(name)
        if m is None or int(m.group(1)) == os.getpid() or not _process_gone(int(m.group(1))):
            continue
        with contextlib.suppress(OSError):
            os.unlink(os.path.join(folder, name))


def stage(target: str, parts) -> str:
    """Write parts whole into a new registered temporary beside target, fsync'd; its path.
    target is the symlink-resolved path, so a link keeps pointing at the new file."""
    folder, name = os.path.split(target)
    remove_dead_temporaries(folder, _FILE_TEMPORARY.format(name=re.escape(name)))
    tmp = temporary_name(target)
    _register(tmp)
    try:
        # O_EXCL: never follow a planted link; mode 0666 lets the umask apply as for open()
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
        with open(fd, "wb") as f:
            _write_parts(f, parts)
            f.flush()
            os.fsync(f.fileno())
        st = _stat(target)
        if st is not None and stat.S_ISREG(st.st_mode):
            os.chmod(tmp, stat.S_IMODE(st.st_mode))  # overwriting keeps the file's permissions
    except BaseException:
        _forget(tmp, remove=True)
        raise
    return tmp


def commit(tmp: str, target: str) -> None:
    """Rename a staged temporary over its target (the temporary is gone either way)."""
    try:
        os.replace(tmp, target)
    except BaseException:
        _forget(tmp, remove=True)
        raise
    _forget(tmp, remove=False)


def _sync_folder(folder: str) -> None:
    with contextlib.suppress(OSError, AttributeError):
        fd = os.open(folder or ".", os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


@contextlib.contextmanager
def _naming(path):
    """An OSError names the target the caller gave, not the temporary."""
    try:
        yield
    except OSError as exc:
        exc.filename, exc.filename2 = os.fspath(path), None
        raise


def write_atomic(path, parts) -> None:
    """Write bytes-like parts (numpy arrays included) to path atomically. OSError as raised."""
    write_group([(path, parts)])


def write_group(files) -> None:
    """Write several files [(path, parts), ...]: every one staged whole first, then renamed
    in order (put the file that names the others, meta.json, last). OSError as raised; a
    failure before the renames leaves every target as it was and no temporaries."""
    targets = [os.path.realpath(os.fspath(p)) for p, _ in files]
    staged = []
    with sigterm_cleans_up():
        try:
            for target, (path, parts) in zip(targets, files):
                st = _stat(target)
                if st is not None and not stat.S_ISREG(st.st_mode):
                    staged.append(None)  # a device or pipe (/dev/stdout): cannot be renamed over
                    continue
                with _naming(path):
                    staged.append(stage(target, parts))
            for target, tmp, (path, parts) in zip(targets, staged, files):
                with _naming(path), replacing(path):
                    if tmp is None:
                        with open(target, "wb") as f:
                            _write_parts(f, parts)
                    else:
                        commit(tmp, target)
        finally:
            for tmp in staged:
                if tmp is not None:
                    _forget(tmp, remove=os.path.lexists(tmp))
        for folder in {os.path.dirname(t) for t, s in zip(targets, staged) if s is not None}:
            _sync_folder(folder)


class Claimed(Exception):
    """Another process holds the claim on an output (its message says which and who)."""


@contextlib.contextmanager
def claim(lock_path: str, what: str):
    """Hold an exclusive claim on an output while the block runs: an flock on lock_path
    (created, and removed when released), taken without waiting; Claimed when another
    process holds it. The kernel drops the lock when its holder dies, even by kill -9, so
    a stale lock file never blocks anyone. Where fcntl is missing (Windows) nothing is
    claimed."""
    try:
        import fcntl
    except ImportError:
        yield
        return
    lock_path = os.path.abspath(lock_path)
    with _sigterm_held():  # no SIGTERM between creating the file and registering it
        fd = _lock(fcntl, lock_path, what)
    if fd is None:  # an unwritable folder: the write itself then says what is wrong
        yield
        return
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        yield
    finally:
        _forget(lock_path, remove=True)  # before the unlock: a waiter then finds a new file
        os.close(fd)


@contextlib.contextmanager
def _sigterm_held():
    mask = getattr(signal, "pthread_sigmask", None)
    if mask is None:
        yield
        return
    old = mask(signal.SIG_BLOCK, {signal.SIGTERM})
    try:
        yield
    finally:
        mask(signal.SIG_SETMASK, old)


def _lock(fcntl, lock_path, what):
    while True:
        try:
            fd = os.open(lock_path, os.O_RDWR | os.O_CREAT, 0o666)
        except OSError:
            return None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            try:
                holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
            except OSError:
                holder = ""
            os.close(fd)
            who = f" (process {holder})" if holder.isdigit() else ""
            raise Claimed(f"{what} is being written by another Splatline run{who}; "
                          "wait for it to end or choose another output") from None
        except BaseException:
            os.close(fd)
            raise
        try:  # the holder before us may have removed the file it locked: lock the one there now
            same = os.fstat(fd).st_ino == os.stat(lock_path).st_ino
        except FileNotFoundError:
            same = False
        if same:
            _register(lock_path)  # a caught SIGTERM removes it with the temporaries
            return fd
        os.close(fd)
