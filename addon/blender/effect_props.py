"""Effect property group (placeholder until its owner fills it in)."""
import bpy


class Effect(bpy.types.PropertyGroup):
    pass


classes = (Effect,)
