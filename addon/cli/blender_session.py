"""Start bpy for the command line: factory settings, the add-on registered."""
from __future__ import annotations

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
