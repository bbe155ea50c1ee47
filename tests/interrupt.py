"""Ctrl+C as a terminal sends it: the one harness of the SIGINT tests (a bpy script, the CLI)."""
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
