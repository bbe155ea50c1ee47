"""Start bpy for the command line: factory settings, the add-on registered."""
from __future__ import annotations


def start(blend_path=None):
    """Import bpy, load blend_path (or an empty factory scene) and register Splatline.

    Returns the bpy module. Safe to call more than once in a process.
    """
    import bpy

    from .. import register

    if blend_path is None:
        bpy.ops.wm.read_factory_settings(use_empty=True)
    else:
        bpy.ops.wm.open_mainfile(filepath=str(blend_path))
    if not hasattr(bpy.types.Object, "splatline"):
        register()
    return bpy
