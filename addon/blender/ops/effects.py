"""Effect-stack operators (add, remove, move, duplicate) and the Look / Effects panels.

Keyframes and drivers on an effect live at 'splatline.effects[i].<prop>'; remove and move
re-point those F-curves so animation stays with its effect.
"""
from __future__ import annotations

import re

import bpy
from bpy.props import EnumProperty

from ..data.pointcloud import is_splat_object
from ..data.animation import channel_fcurves, remove_fcurve
from ..props.effect import FIELDS, TYPES

_PATH = re.compile(r"^splatline\.effects\[(\d+)\]")


def remap_effect_curves(obj, mapping: dict) -> None:
    """Re-point F-curves of effect i to effect mapping[i] (None: delete the curve)."""
    doomed = []
    for curve in channel_fcurves(obj):
        match = _PATH.match(curve.data_path)
        if match is None:
            continue
        old = int(match.group(1))
        if old not in mapping:
            continue
        new = mapping[old]
        if new is None:
            doomed.append(curve)
        else:
            curve.data_path = f"splatline.effects[{new}]" + curve.data_path[match.end():]
    for curve in doomed:
        remove_fcurve(obj, curve)


def _effects(context):
    return context.object.splatline.effects


class _EffectOperator:
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return is_splat_object(context.object)

    def finish(self, context):
        context.object.update_tag(refresh={"TIME"})
        return {"FINISHED"}

    def append(self, context, fill):
        """A new effect at the end of the stack, filled by fill(effect), made the active one."""
        settings = context.object.splatline
        fill(settings.effects.add())
        settings.active_effect = len(settings.effects) - 1
        return self.finish(context)

    def restack(self, context, mapping: dict, change, active: int):
        """Re-point the effects' F-curves (remap_effect_curves' mapping), then change(effects)
        and make effect `active` the active one."""
        remap_effect_curves(context.object, mapping)
        change(context.object.splatline.effects)
        context.object.splatline.active_effect = active
        return self.finish(context)


class SPLATLINE_OT_effect_add(_EffectOperator, bpy.types.Operator):
    """Add an effect to the bottom of the active splat object's stack"""
    bl_idname = "splatline.effect_add"
    bl_label = "Add Effect"
    type: EnumProperty(name="Type", items=TYPES)

    def execute(self, context):
        return self.append(context, self._new)

    def _new(self, effect):
        effect.type = self.type
        effect.name = next(t[1] for t in TYPES if t[0] == self.type)


class SPLATLINE_OT_effect_remove(_EffectOperator, bpy.types.Operator):
    """Remove the active effect (and its keyframes)"""
    bl_idname = "splatline.effect_remove"
    bl_label = "Remove Effect"

    def execute(self, context):
        settings = context.object.splatline
        index, count = settings.active_effect, len(settings.effects)
        if not 0 <= index < count:
            return {"CANCELLED"}
        mapping = {i: (None if i == index else i - (i > index)) for i in range(count)}
        return self.restack(context, mapping, lambda effects: effects.remove(index),
                            max(0, min(index, count - 2)))


class SPLATLINE_OT_effect_move(_EffectOperator, bpy.types.Operator):
    """Move the active effect up or down the stack (effects apply top to bottom)"""
    bl_idname = "splatline.effect_move"
    bl_label = "Move Effect"
    direction: EnumProperty(items=(("UP", "Up", ""), ("DOWN", "Down", "")))

    def execute(self, context):
        settings = context.object.splatline
        index = settings.active_effect
        other = index - 1 if self.direction == "UP" else index + 1
        if not (0 <= index < len(settings.effects) and 0 <= other < len(settings.effects)):
            return {"CANCELLED"}
        return self.restack(context, {index: other, other: index},
                            lambda effects: effects.move(index, other), other)


class SPLATLINE_OT_effect_duplicate(_EffectOperator, bpy.types.Operator):
    """Duplicate the active effect's current values (not its keyframes) below the stack"""
    bl_idname = "splatline.effect_duplicate"
    bl_label = "Duplicate Effect"

    def execute(self, context):
        settings = context.object.splatline
        if not 0 <= settings.active_effect < len(settings.effects):
            return {"CANCELLED"}
        source = settings.effects[settings.active_effect]

        def copy_of_source(copy):
            for prop in source.bl_rna.properties:
                if prop.identifier != "rna_type" and not prop.is_readonly:
                    setattr(copy, prop.identifier, getattr(source, prop.identifier))
            copy.name = source.name + ".copy"
        return self.append(context, copy_of_source)


class SPLATLINE_OT_effect_add_gizmo(_EffectOperator, bpy.types.Operator):
    """Add an Empty as the active effect's gizmo where its field already is, so nothing changes until it moves"""
    bl_idname = "splatline.effect_add_gizmo"
    bl_label = "Add Gizmo Empty"

    def execute(self, context):
        obj = context.object
        settings = obj.splatline
        if not 0 <= settings.active_effect < len(settings.effects):
            return {"CANCELLED"}
        effect = settings.effects[settings.active_effect]
        empty = bpy.data.objects.new(f"{obj.name} {effect.name} gizmo", None)
        empty.empty_display_type = "SPHERE" if effect.type == "REVEAL" and effect.reveal_shape == "SPHERE" \
            else "ARROWS"
        empty.location = obj.matrix_world.translation
        for collection in obj.users_collection:
            collection.objects.link(empty)
        if not empty.users_collection:
            context.scene.collection.objects.link(empty)
        effect.gizmo = empty
        return self.finish(context)


class SPLATLINE_UL_effects(bpy.types.UIList):
    def draw_item(self, _context, layout, _data, item, _icon, _active_data, _active_prop, _index=0):
        icon = next(t[3] for t in TYPES if t[0] == item.type)
        row = layout.row(align=True)
        row.prop(item, "name", text="", emboss=False, icon=icon)
        row.prop(item, "amount", text="")
        row.prop(item, "enabled", text="", icon="HIDE_OFF" if item.enabled else "HIDE_ON", emboss=False)


class _ObjectPanel:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        return is_splat_object(context.object)


class SPLATLINE_PT_look(_ObjectPanel, bpy.types.Panel):
    bl_label = "Splatline Look"
    bl_idname = "SPLATLINE_PT_look"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        look = context.object.splatline.look
        for name in ("visible", "opacity", "size", "tint", "exposure", "saturation", "hue", "max_sh_degree"):
            layout.prop(look, name)


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
        col.operator_menu_enum(SPLATLINE_OT_effect_add.bl_idname, "type", text="", icon="ADD")
        col.operator(SPLATLINE_OT_effect_remove.bl_idname, text="", icon="REMOVE")
        col.operator(SPLATLINE_OT_effect_duplicate.bl_idname, text="", icon="DUPLICATE")
        col.separator()
        col.operator(SPLATLINE_OT_effect_move.bl_idname, text="", icon="TRIA_UP").direction = "UP"
        col.operator(SPLATLINE_OT_effect_move.bl_idname, text="", icon="TRIA_DOWN").direction = "DOWN"
        if not 0 <= settings.active_effect < len(settings.effects):
            return
        effect = settings.effects[settings.active_effect]
        layout.use_property_split = True
        for name in ("type", "enabled", "amount"):
            layout.prop(effect, name)
        row = layout.row(align=True)
        row.prop(effect, "gizmo")
        if effect.gizmo is None:
            row.operator(SPLATLINE_OT_effect_add_gizmo.bl_idname, text="", icon="EMPTY_AXIS")
        for name in FIELDS[effect.type]:
            layout.prop(effect, name)


classes = (SPLATLINE_OT_effect_add, SPLATLINE_OT_effect_remove, SPLATLINE_OT_effect_move,
           SPLATLINE_OT_effect_duplicate, SPLATLINE_OT_effect_add_gizmo, SPLATLINE_UL_effects, SPLATLINE_PT_look,
           SPLATLINE_PT_look_crop, SPLATLINE_PT_effects)


register, unregister = bpy.utils.register_classes_factory(classes)
