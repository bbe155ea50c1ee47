"""A small file system for full-disk tests: a tmpfs mounted on a folder (root on Linux), filled
until only a given number of bytes is free. Where mounting is not allowed the test is skipped
with the reason."""
from __future__ import annotations

import contextlib
import os
import subprocess

import pytest


@contextlib.contextmanager
def small_disk(folder, size_mb: int = 20):
    """A tmpfs of size_mb at folder for the block, unmounted after."""
    folder = str(folder)
    os.makedirs(folder, exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_mb}m", "tmpfs", folder],
                       capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here: {(r.stderr or r.stdout).strip() or r.returncode}")
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", folder], capture_output=True)


def leave_free(folder, nbytes: int) -> None:
    """Fill the file system of folder until about nbytes are free (whole pages)."""
    st = os.statvfs(folder)
    fill = st.f_bavail * st.f_frsize - nbytes
    if fill > 0:
        with open(os.path.join(folder, "filler"), "wb") as f:
            f.write(b"\0" * fill)
