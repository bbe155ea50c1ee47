"""Start bpy for the command line: factory settings, the add-on registered."""
from __future__ import annotations


def start(blend_path=None):
    """Import bpy, load blend_path (or an empty factory scene) and register Splatline.

    Returns the bpy module. Safe to call more than once in a process.
    """
    import bpy

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
