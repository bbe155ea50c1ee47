"""DisplaySettings property group (placeholder until its owner fills it in)."""
import bpy


class DisplaySettings(bpy.types.PropertyGroup):
    pass


classes = (DisplaySettings,)
