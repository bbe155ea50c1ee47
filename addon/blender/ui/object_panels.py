"""The Object-properties panels of a splat object: Splat Sequence, Look (and its Crop) and
the Effects stack with its list. Registered in this order, which is the order Blender shows
them in. The operators they show are ops/sequence.py's and ops/effects.py's, named by
bl_idname (ui/ does not import ops/); effect presets add their menu to the Effects panel
(ui/presets.py).
"""
from __future__ import annotations

import bpy

from ..data.sources import is_splat_object
from ..data import native, sequence_source
from ..props.effect import FIELDS, TYPES


def _sequence_object(context):
    obj = context.active_object
    return obj if is_splat_object(obj, with_splat_data=True) else None


class _ObjectPanel:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        return is_splat_object(context.object)


class OBJECT_PT_splatline_sequence(_ObjectPanel, bpy.types.Panel):
    bl_label = "Splat Sequence"
    bl_idname = "OBJECT_PT_splatline_sequence"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return _sequence_object(context) is not None

    def draw(self, context):
        obj = _sequence_object(context)
        seq = obj.splatline.sequence
        layout = self.layout
        layout.use_property_split = True
        layout.prop(seq, "enabled")
        if seq.enabled:
            col = layout.column()
            col.prop(seq, "directory")
            col.label(text=f"{seq.prefix}{'#' * seq.digits}{seq.suffix}, {seq.frame_count} frames "
                           f"from {seq.first_number}")
            col.prop(seq, "start_frame")
            col.prop(seq, "frame_offset")
            col.prop(seq, "speed")
            col.prop(seq, "loop_mode")
            col.prop(seq, "cache_budget_mb")
            col.prop(seq, "read_ahead")
            problem = sequence_source.report_for(obj)
            if problem:
                layout.label(text=problem, icon="ERROR")
        layout.operator("splatline.bake_sequence", icon="RENDER_ANIMATION")


class OBJECT_PT_splatline_dynamic(_ObjectPanel, bpy.types.Panel):
    bl_label = "Dynamic Capture"
    bl_idname = "OBJECT_PT_splatline_dynamic"

    @classmethod
    def poll(cls, context):
        obj = context.object
        return is_splat_object(obj) and obj.splatline.dynamic.enabled

    def draw(self, context):
        dynamic = context.object.splatline.dynamic
        layout = self.layout
        layout.use_property_split = True
        unit = "s" if dynamic.unit == "SECONDS" else " segments"
        layout.label(text=f"{dynamic.model}: {dynamic.time_start:g} to {dynamic.time_end:g}{unit}")
        col = layout.column()
        col.prop(dynamic, "start_frame")
        col.prop(dynamic, "frames_per_unit")
        col.prop(dynamic, "mode")
        col.prop(dynamic, "use_capture_time")
        sub = col.column()
        sub.active = dynamic.use_capture_time
        sub.prop(dynamic, "capture_time")


class SPLATLINE_UL_effects(bpy.types.UIList):
    def draw_item(self, _context, layout, _data, item, _icon, _active_data, _active_prop, _index=0):
        icon = next(t[3] for t in TYPES if t[0] == item.type)
        row = layout.row(align=True)
        row.prop(item, "name", text="", emboss=False, icon=icon)
        row.prop(item, "amount", text="")
        row.prop(item, "enabled", text="", icon="HIDE_OFF" if item.enabled else "HIDE_ON", emboss=False)


# Splatline's viewport lights in its shader, without shadows; on 5.3 Blender draws its own
# splats (unlit) in Solid and Material Preview, and Splatline's drawing is Rendered shading's
VIEWPORT_LIGHTING_HINT = "Viewport: lit without shadows; renders cast them"
NATIVE_LIGHTING_HINT = "Lit by the Splatline engine only; its viewport casts no shadows"


def lighting_hint(obj) -> str:
    return NATIVE_LIGHTING_HINT if native.drawn_natively(obj.data) else VIEWPORT_LIGHTING_HINT


class SPLATLINE_PT_look(_ObjectPanel, bpy.types.Panel):
    bl_label = "Splatline Look"
    bl_idname = "SPLATLINE_PT_look"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        look = context.object.splatline.look
        for name in ("visible", "opacity", "size", "tint", "exposure", "saturation", "hue", "lighting",
                     "max_sh_degree"):
            layout.prop(look, name)
            if name == "lighting" and look.lighting > 0:
                layout.label(text=lighting_hint(context.object), icon="INFO")
        layout.prop(context.object.splatline, "antialiased")


class SPLATLINE_PT_look_crop(_ObjectPanel, bpy.types.Panel):
    bl_label = "Crop"
    bl_idname = "SPLATLINE_PT_look_crop"
    bl_parent_id = "SPLATLINE_PT_look"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        look = context.object.splatline.look
        for shape, extent in (("crop_box", "crop_box_size"), ("crop_sphere", "crop_sphere_radius")):
            layout.prop(look, f"use_{shape}")
            col = layout.column()
            col.active = getattr(look, f"use_{shape}")
            for name in (f"{shape}_center", extent, f"{shape}_softness", f"{shape}_invert"):
                col.prop(look, name)


class SPLATLINE_PT_effects(_ObjectPanel, bpy.types.Panel):
    bl_label = "Splatline Effects"
    bl_idname = "SPLATLINE_PT_effects"

    def draw(self, context):
        layout = self.layout
        settings = context.object.splatline
        row = layout.row()
        row.template_list("SPLATLINE_UL_effects", "", settings, "effects", settings, "active_effect", rows=4)
        col = row.column(align=True)
        col.operator_menu_enum("splatline.effect_add", "type", text="", icon="ADD")
        col.operator("splatline.effect_remove", text="", icon="REMOVE")
        col.operator("splatline.effect_duplicate", text="", icon="DUPLICATE")
        col.separator()
        col.operator("splatline.effect_move", text="", icon="TRIA_UP").direction = "UP"
        col.operator("splatline.effect_move", text="", icon="TRIA_DOWN").direction = "DOWN"
        if not 0 <= settings.active_effect < len(settings.effects):
            return
        effect = settings.effects[settings.active_effect]
        layout.use_property_split = True
        for name in ("type", "enabled", "amount"):
            layout.prop(effect, name)
        row = layout.row(align=True)
        row.prop(effect, "gizmo")
        if effect.gizmo is None:
            row.operator("splatline.effect_add_gizmo", text="", icon="EMPTY_AXIS")
        for name in FIELDS[effect.type]:
            layout.prop(effect, name)


classes = (OBJECT_PT_splatline_sequence, OBJECT_PT_splatline_dynamic, SPLATLINE_UL_effects,
           SPLATLINE_PT_look, SPLATLINE_PT_look_crop, SPLATLINE_PT_effects)


register, unregister = bpy.utils.register_classes_factory(classes)
