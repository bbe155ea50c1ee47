"""Object > Splatline in the 3D view: the effect-stack and bake operators in a menu.

Blender's F3 search finds operators through the menus that show them, so operators that
only sat in panels were out of its reach. Import and export are in File > Import/Export
(io_ops.py, sequence_ops.py); the render-output presets are in Output properties.
"""
from __future__ import annotations

import bpy

from ..registration import classes_and_menus


class SPLATLINE_MT_object(bpy.types.Menu):
    bl_idname = "SPLATLINE_MT_object"
    bl_label = "Splatline"

    def draw(self, context):
        layout = self.layout
        layout.operator_menu_enum("splatline.effect_add", "type", icon="ADD")
        layout.menu("SPLATLINE_MT_effect_presets", icon="PRESET")
        layout.operator("splatline.effect_add_gizmo", icon="EMPTY_AXIS")
        layout.operator("splatline.effect_duplicate", icon="DUPLICATE")
        layout.operator("splatline.effect_remove", icon="REMOVE")
        layout.separator()
        layout.operator("splatline.bake_sequence", icon="RENDER_ANIMATION")
        layout.operator("export_scene.splatline_evaluated", text="Export Evaluated Splats", icon="EXPORT")


def _draw_in_object_menu(self, context):
    self.layout.separator()
    self.layout.menu(SPLATLINE_MT_object.bl_idname)


register, unregister = classes_and_menus((SPLATLINE_MT_object,),
                                         (("VIEW3D_MT_object", _draw_in_object_menu),))
