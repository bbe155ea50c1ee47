"""The preset menus: render-output presets in the Output properties (with the + and - of
ops/presets.py), effect presets at the foot of the Effects panel and in Object > Splatline.

The preset files are data/presets.py's and data/effect_presets.py's; operators are named by
their bl_idname, as ui/ does not import ops/.
"""
from __future__ import annotations

import bpy

from ..data import effect_presets
from ..data.presets import RENDER_MENU, RENDER_SUBDIR, list_presets, preset_dirs

RENDER_PRESET_ADD = "splatline.render_preset_add"


class SPLATLINE_MT_render_presets(bpy.types.Menu):
    bl_idname = RENDER_MENU
    bl_label = "Splatline Output Presets"
    preset_subdir = RENDER_SUBDIR
    preset_operator = "script.execute_preset"

    def draw(self, context):
        self.path_menu([str(d) for d in preset_dirs("render")], "script.execute_preset",
                       props_default={"menu_idname": self.bl_idname},
                       filter_ext=lambda ext: ext.lower() == ".py")


class SPLATLINE_PT_output_presets(bpy.types.Panel):
    """Output presets beside Blender's own output settings, for the Splatline engine."""
    bl_label = "Splatline Output"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "output"
    COMPAT_ENGINES = {"SPLATLINE"}

    @classmethod
    def poll(cls, context):
        return context.scene.render.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        row = self.layout.row(align=True)
        row.menu(SPLATLINE_MT_render_presets.__name__, text=SPLATLINE_MT_render_presets.bl_label)
        row.operator(RENDER_PRESET_ADD, text="", icon="ADD")
        remove = row.operator(RENDER_PRESET_ADD, text="", icon="REMOVE")
        remove.remove_active = True


class SPLATLINE_MT_effect_presets(bpy.types.Menu):
    bl_idname = "SPLATLINE_MT_effect_presets"
    bl_label = "Effect Presets"

    def draw(self, context):
        layout = self.layout
        for name, path in list_presets("effects", ".json").items():
            label = effect_presets.label(path)
            layout.operator("splatline.effect_preset_apply", text=label).preset = name
        layout.separator()
        layout.operator("splatline.effect_preset_add", icon="ADD")
        layout.menu(SPLATLINE_MT_effect_presets_remove.bl_idname, icon="REMOVE")


class SPLATLINE_MT_effect_presets_remove(bpy.types.Menu):
    bl_idname = "SPLATLINE_MT_effect_presets_remove"
    bl_label = "Remove Saved Preset"

    def draw(self, context):
        try:
            paths = sorted(effect_presets.user_dir().glob("*.json"))
        except OSError:  # no user folder: nothing saved to remove
            paths = []
        for path in paths:
            self.layout.operator("splatline.effect_preset_remove",
                                 text=effect_presets.label(path)).preset = path.stem


def _draw_in_effects_panel(self, context):
    self.layout.menu(SPLATLINE_MT_effect_presets.bl_idname, icon="PRESET")


classes = (SPLATLINE_MT_render_presets, SPLATLINE_PT_output_presets,
           SPLATLINE_MT_effect_presets_remove, SPLATLINE_MT_effect_presets)


def _effects_panel():
    return getattr(bpy.types, "SPLATLINE_PT_effects", None)


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)


def register():
    _register_classes()
    panel = _effects_panel()
    if panel is not None:
        panel.append(_draw_in_effects_panel)


def unregister():
    panel = _effects_panel()
    if panel is not None:
        panel.remove(_draw_in_effects_panel)
    _unregister_classes()
