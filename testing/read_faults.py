"""Fault injection for the readers: change a file at a chosen block of its read, through the
test hook `core/formats/readfile.after_block` (no sleeps: the change lands at the same byte
every run), in this process or in a `python -m addon` child."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

from testing.paths import REPO

ACTIONS = ("truncate", "grow", "replace", "rewrite", "delete")
# what each action must make a read say (delete: nothing, the bytes read are whole)
REASONS = {"truncate": "while it was read", "grow": "changed size while it was read",
           "replace": "replaced while it was read", "rewrite": "rewritten while it was read",
           "delete": None}


def change(path, action: str, donor=None) -> None:
    """Do `action` to the file at path (donor: the file a replace renames over it)."""
    size = os.path.getsize(path)
    if action == "truncate":
        os.truncate(path, size // 3)
    elif action == "grow":
        with open(path, "ab") as f:
            f.write(b"\0" * 4096)
    elif action == "replace":
        tmp = f"{path}.new"
        shutil.copyfile(donor, tmp)
        os.replace(tmp, path)
    elif action == "rewrite":  # same size, other bytes: only the modification time tells
        with open(path, "r+b") as f:
            f.seek(size // 2)
            f.write(bytes(16))
    elif action == "delete":
        os.remove(path)
    else:
        raise ValueError(action)


def age(path) -> None:
    """Date the file back a minute, so an in-place rewrite moves its modification time
    even on a file system with coarse timestamps."""
    old = os.stat(path).st_mtime - 60
    os.utime(path, (old, old))


def hook(target, action: str, at_block: int, donor=None):
    """An after_block callback changing target once, after block at_block of its read."""
    target = os.path.realpath(target)
    done = []

    def after_block(path, k):
        if not done and k == at_block and os.path.realpath(path) == target:
            done.append(k)
            change(target, action, donor)
    after_block.done = done
    return after_block


_CHILD = r"""
import json, runpy, sys
from testing.read_faults import hook
from addon.core.formats import readfile
spec = json.loads(sys.argv[1])
readfile.BLOCK = spec["block"]
readfile.after_block = hook(spec["target"], spec["action"], spec["at_block"], spec.get("donor"))
sys.argv = ["python -m addon", *sys.argv[2:]]
runpy.run_module("addon", run_name="__main__", alter_sys=True)
"""


def cli_with_fault(target, action: str, at_block: int, *args, block=256, donor=None, timeout=300):
    """`python -m addon ARGS` with target changed at block at_block: (exit code, stdout, stderr).
    A child killed by a signal shows as a negative exit code."""
    spec = {"target": os.fspath(target), "action": action, "at_block": at_block, "block": block,
            "donor": None if donor is None else os.fspath(donor)}
    res = subprocess.run([sys.executable, "-c", _CHILD, json.dumps(spec), *map(str, args)],
                         cwd=REPO, capture_output=True, text=True, timeout=timeout)
    return res.returncode, res.stdout, res.stderr
