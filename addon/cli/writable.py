"""Can the command write where it is told to? Checked before any input is read, so a missing
or read-only output folder is one line naming it, not a writer's late, misleading error
(an unbundled SOG said "cannot write WebP: no WebP support"; Blender "Render error (Success)")."""
from __future__ import annotations

import os
import tempfile

from . import UserError


def check_folder(folder, what: str, name=None) -> None:
    """`folder` exists, is a folder, and a file can be made in it: tried, not guessed from
    mode bits (root ignores them; a read-only file system or /proc does not). The error
    names `name` (the output asked for) where given, else the folder."""
    folder = os.fspath(folder) or "."
    head = f"{os.fspath(name)}: folder {folder}" if name is not None else folder
    if not os.path.exists(folder):
        raise UserError(f"{head}: no such folder (for {what})")
    if not os.path.isdir(folder):
        raise UserError(f"{head}: not a folder (for {what})")
    try:
        fd, probe = tempfile.mkstemp(prefix=".splatline-probe-", dir=folder)
    except OSError as exc:
        raise UserError(f"{head}: cannot write {what} in this folder: "
                        f"{exc.strerror or type(exc).__name__}") from None
    os.close(fd)
    os.unlink(probe)


def check_output_file(path, what: str = "the output") -> None:
    """The folder an output file goes into (a file on stdout or a device is left alone)."""
    path = os.fspath(path)
    if path.startswith("/dev/"):
        return
    check_folder(os.path.dirname(os.path.abspath(path)), what, path)
