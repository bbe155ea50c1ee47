"""`python -m addon` with its peak memory measured, and the one-line error every bad input or
option must give (`error: WHAT: WHY`)."""
from __future__ import annotations

import json
import subprocess
import sys

from testing.paths import REPO

# Runs the CLI as its own child, so RUSAGE_CHILDREN is that one command's peak alone
# (pytest's own RUSAGE_CHILDREN keeps the largest child any earlier test ran).
_MEASURE = r"""
import json, resource, subprocess, sys
r = subprocess.run(sys.argv[1:], capture_output=True, text=True)
print(json.dumps({"rc": r.returncode, "out": r.stdout, "err": r.stderr,
                  "peak": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024}))
"""


def cli(*args, timeout=180):
    """(exit code, stdout, stderr, the command's peak RSS in bytes)."""
    cmd = [sys.executable, "-c", _MEASURE, sys.executable, "-m", "addon", *map(str, args)]
    res = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=timeout)
    assert res.returncode == 0, res.stderr
    r = json.loads(res.stdout.strip().splitlines()[-1])
    return r["rc"], r["out"], r["err"], r["peak"]


def one_line(err: str, *words) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("error: "), err
    assert "Traceback" not in err, err
    for w in words:
        assert w.lower() in lines[0].lower(), err
    return lines[0]
