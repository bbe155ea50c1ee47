"""register()/unregister() for a module's classes and the draw functions it adds to
Blender's own menus: beside the rooms (as compat.py), any room may use it.

Classes go through bpy.utils.register_classes_factory (in order; unregistered in reverse),
then each draw function is appended to its menu; unregister removes them first.
"""
from __future__ import annotations

import bpy


def classes_and_menus(classes, menu_entries=()):
    """(register, unregister) for `classes` and (menu name in bpy.types, draw) pairs."""
    register_classes, unregister_classes = bpy.utils.register_classes_factory(tuple(classes))

    def register():
        register_classes()
        for menu, draw in menu_entries:
            getattr(bpy.types, menu).append(draw)

    def unregister():
        for menu, draw in reversed(menu_entries):
            getattr(bpy.types, menu).remove(draw)
        unregister_classes()

    return register, unregister


def app_handlers(pairs, on_unregister=None):
    """(register, unregister) for (bpy.app.handlers list, function) pairs: each function is
    added once, and removed wherever it is; `on_unregister` runs last (a cache's clear)."""
    def register():
        for handlers, fn in pairs:
            if fn not in handlers:
                handlers.append(fn)

    def unregister():
        for handlers, fn in pairs:
            while fn in handlers:
                handlers.remove(fn)
        if on_unregister is not None:
            on_unregister()

    return register, unregister
