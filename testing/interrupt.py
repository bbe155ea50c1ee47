"""Child processes stopped on cue: Ctrl+C as a terminal sends it (the one harness of the SIGINT
tests: a bpy script, the CLI), and the wait for a child to reach a point it marks with a file
(the kill and claim tests).

A child that pauses for its signal sleeps in short slices, never one long sleep: a signal
sent to a process may be delivered to any of its threads that does not block it (numpy's
OpenBLAS threads, Blender's), and then it does not interrupt the main thread's sleep; Python
runs the handler only when that sleep returns (a 60 s hang seen once in CI)."""
from __future__ import annotations

import signal
import subprocess
import time


def interrupt_after(command, first_output, cwd=None, timeout=60) -> tuple[int, str, str]:
    """Run `command`, send it SIGINT once `first_output` (a path) exists, and return
    (returncode, stdout, stderr) once it has ended.

    SIGINT starts at its default in the child, as from a terminal: pytest-xdist workers
    ignore SIGINT, a child would inherit that, and Python then leaves it ignored."""
    proc = subprocess.Popen(command, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + timeout
        while not first_output.exists():
            assert proc.poll() is None and time.monotonic() < deadline, "no first frame"
            time.sleep(0.02)
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, stdout, stderr


def wait_for_marker(proc, marker, timeout=120) -> None:
    """Wait until the child `proc` creates the file `marker` (the point it pauses at). A child
    that ends first, or never gets there (then killed), fails the test with its output."""
    t0 = time.monotonic()
    while not marker.exists():
        if proc.poll() is not None:
            out, err = (b.decode() if isinstance(b, bytes) else b or "" for b in proc.communicate())
            raise AssertionError(f"the child ended (rc {proc.returncode}) before its marker: "
                                 f"{out[-1500:]} {err[-1500:]}")
        if time.monotonic() - t0 > timeout:
            proc.kill()
            raise AssertionError(f"the child never reached its marker in {timeout} s")
        time.sleep(0.02)


def finish_or_dump(proc, timeout=60) -> tuple[bytes, bytes]:
    """proc.communicate(timeout), for a child started with `-X faulthandler`: one that has
    not ended by then is sent SIGABRT, whose handler prints every thread's Python stack,
    and the test fails with that stack (a hang seen once in CI left only "timed out")."""
    try:
        return proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGABRT)
        try:
            _, err = proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            _, err = proc.communicate()
        err = err.decode(errors="replace") if isinstance(err, bytes) else err or ""
        raise AssertionError(f"the child had not ended {timeout} s after its signal; its threads:\n"
                             f"{err[-4000:]}") from None
