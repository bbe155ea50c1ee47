"""The command line starts OpenBLAS with one thread but for convert (SOG's k-means), and
never over the user's own setting: checked in fresh processes, by the threads numpy's
import leaves running."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# the module's start as `python -m addon <command>` runs it (sys.argv set first), then
# the process's threads once numpy is loaded
PROBE = ("import os, sys; sys.argv = ['addon', sys.argv[1]]; import addon.__main__; "
         "print(os.environ.get('OPENBLAS_NUM_THREADS'), len(os.listdir('/proc/self/task')))")


def _start(command: str, **env) -> tuple[str, int]:
    environ = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    done = subprocess.run([sys.executable, "-c", PROBE, command], cwd=ROOT, env={**environ, **env},
                          capture_output=True, text=True, check=True)
    setting, threads = done.stdout.split()
    return setting, int(threads)


@pytest.mark.parametrize("command", ("import", "render", "info", "demo"))
def test_commands_without_products_start_one_blas_thread(command):
    assert _start(command) == ("1", 1)


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="one core: OpenBLAS starts no thread of its own")
def test_convert_keeps_a_thread_per_core_and_the_users_setting_stands():
    setting, threads = _start("convert")
    assert setting == "None" and threads > 1
    assert _start("import", OPENBLAS_NUM_THREADS="2") == ("2", 2)
