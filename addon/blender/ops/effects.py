"""Effect-stack operators (add, remove, move, duplicate, add a gizmo); the Look and Effects
panels that show them are ui/object_panels.py's.

Keyframes and drivers on an effect live at 'splatline.effects[i].<prop>'; remove and move
re-point those F-curves so animation stays with its effect.
"""
from __future__ import annotations

import re

import bpy
from bpy.props import EnumProperty

from ..data.sources import is_splat_object
from ..data.animation import channel_fcurves, remove_fcurve
from ..props.effect import TYPES

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


classes = (SPLATLINE_OT_effect_add, SPLATLINE_OT_effect_remove, SPLATLINE_OT_effect_move,
           SPLATLINE_OT_effect_duplicate, SPLATLINE_OT_effect_add_gizmo)


register, unregister = bpy.utils.register_classes_factory(classes)
