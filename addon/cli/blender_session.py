"""Start bpy for the command line: factory settings, the add-on registered."""
from __future__ import annotations

import os
import sys


def start(blend_path=None):
    """Import bpy, load blend_path (or an empty factory scene) and register Splatline.

    Returns the bpy module. Safe to call more than once in a process. Without bpy (a
    `pip install .` without the blender extra), one line says what to install.
    """
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
        bpy.ops.wm.open_mainfile(filepath=str(blend_path))
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
            try:
                result = bpy.ops.wm.save_as_mainfile(filepath=path, check_existing=False)
            finally:
                paths.save_version = versions
    except atomic.Claimed as exc:
        raise UserError(f"{path}: {exc}") from None
    except RuntimeError as exc:  # Blender reports a failed save as an error report
        raise UserError(f"{path}: cannot save: {' '.join(str(exc).split())}") from None
    if "FINISHED" not in result:
        raise UserError(f"{path}: Blender could not save the .blend")
