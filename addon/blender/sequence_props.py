"""SequenceSettings property group (placeholder until its owner fills it in)."""
import bpy


class SequenceSettings(bpy.types.PropertyGroup):
    pass


classes = (SequenceSettings,)
