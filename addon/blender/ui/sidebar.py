"""The N-sidebar's Splatline tab: the timeline tools for the active splat object.

Everything here is a shortcut to properties and operators that live elsewhere (look,
effect stack, sequence timing, presets, bake), laid out for animating beside the
timeline; the Object-properties panels stay the full editors. The Viewport Statistics
panel (viewport/ui.py) sits below it in the same tab.
"""
from __future__ import annotations

import bpy

from ..data.sources import is_splat_object
from ..props.effect import TYPES

CATEGORY = "Splatline"


class _SidebarPanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = CATEGORY


class SPLATLINE_PT_animate(_SidebarPanel, bpy.types.Panel):
    """Fades, effects and presets of the active splat object, keyed at the current frame"""
    bl_label = "Animate"
    bl_idname = "SPLATLINE_PT_animate"
    bl_order = 0

    def draw(self, context):
        layout = self.layout
        obj = context.active_object
        if not is_splat_object(obj):
            layout.label(text="Select a splat object", icon="INFO")
            layout.operator("import_scene.splatline_gaussians", icon="IMPORT")
            return
        layout.use_property_split = True
        layout.use_property_decorate = True  # the keyframe dots: click or I key to key
        look = obj.splatline.look
        col = layout.column()
        for name in ("opacity", "size", "exposure"):
            col.prop(look, name)
        layout.menu("SPLATLINE_MT_effect_presets", icon="PRESET")
        _draw_effects(layout, obj.splatline)
        if obj.splatline.sequence.enabled:
            _draw_sequence(layout, obj.splatline.sequence)


def _draw_effects(layout, settings):
    """One row per effect: on/off and its keyable blend amount; the full editor is the
    Object-properties panel."""
    box = layout.box()
    header = box.row()
    header.label(text="Effects")
    header.operator_menu_enum("splatline.effect_add", "type", text="", icon="ADD")
    icons = {t[0]: t[3] for t in TYPES}
    for effect in settings.effects:
        row = box.row(align=True)
        row.prop(effect, "enabled", text="", icon="HIDE_OFF" if effect.enabled else "HIDE_ON", emboss=False)
        row.prop(effect, "amount", text=effect.name, icon=icons[effect.type])


def _draw_sequence(layout, sequence):
    box = layout.box()
    box.label(text="Sequence Timing")
    for name in ("frame_offset", "speed", "loop_mode"):
        box.prop(sequence, name)


class SPLATLINE_PT_animate_output(_SidebarPanel, bpy.types.Panel):
    """Bake the animation to files, or render it"""
    bl_label = "Bake and Render"
    bl_idname = "SPLATLINE_PT_animate_output"
    bl_parent_id = SPLATLINE_PT_animate.bl_idname
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return is_splat_object(context.active_object)

    def draw(self, context):
        col = self.layout.column(align=True)
        col.operator("splatline.bake_sequence", icon="RENDER_ANIMATION")
        col.operator("export_scene.splatline_evaluated", text="Export Evaluated Splats", icon="EXPORT")
        col.separator()
        col.operator("render.render", text="Render Animation", icon="RENDER_RESULT").animation = True


classes = (SPLATLINE_PT_animate, SPLATLINE_PT_animate_output)


register, unregister = bpy.utils.register_classes_factory(classes)
