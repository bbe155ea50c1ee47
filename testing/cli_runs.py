"""Running `python -m addon` as a user or a farm runs it: each command in its own process,
from the repository root."""
from __future__ import annotations

import subprocess
import sys

from testing.paths import REPO


def cli(*args, timeout=120):
    """`python -m addon ARGS`, run to the end; the CompletedProcess (text output)."""
    return subprocess.run([sys.executable, "-m", "addon", *map(str, args)], cwd=REPO,
                          capture_output=True, text=True, timeout=timeout)


def render_command(*args):
    return [sys.executable, "-m", "addon", "render", *map(str, args)]


def run_all(commands, timeout=300):
    """Run commands two at a time (the test machines have two cores); each must exit 0.
    [(exit code, stdout, stderr)] in the order given."""
    results = []
    for i in range(0, len(commands), 2):
        procs = [subprocess.Popen(c, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                  text=True) for c in commands[i:i + 2]]
        results += [(p.wait(timeout), *p.communicate()) for p in procs]
    for rc, out, err in results:
        assert rc == 0, out + err
    return results


def render_all(arg_lists, timeout=180):
    """run_all for `python -m addon render` with each of arg_lists."""
    return run_all([render_command(*args) for args in arg_lists], timeout)

