"""LookSettings property group (placeholder until its owner fills it in)."""
import bpy


class LookSettings(bpy.types.PropertyGroup):
    pass


classes = (LookSettings,)
