# SPDX-License-Identifier: GPL-3.0-or-later
"""Splatline add-on package.

core/     pure numpy (no bpy): formats, splat math, sorting, effects, reference renderer
gl/       moderngl offscreen renderer
blender/  everything that imports bpy
"""


def register():
    from .blender import register as _register
    _register()


def unregister():
    from .blender import unregister as _unregister
    _unregister()
