"""RenderSettings property group (placeholder until its owner fills it in)."""
import bpy


class RenderSettings(bpy.types.PropertyGroup):
    pass


classes = (RenderSettings,)
