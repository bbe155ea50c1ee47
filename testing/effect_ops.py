"""Adding an effect to an object the way a user does: through the real operator."""
from __future__ import annotations


def add_effect(bpy, obj, kind, **props):
    bpy.context.view_layer.objects.active = obj
    with bpy.context.temp_override(object=obj):
        assert bpy.ops.splatline.effect_add(type=kind) == {"FINISHED"}
    effect = obj.splatline.effects[-1]
    for name, value in props.items():
        setattr(effect, name, value)
    return effect
