"""Root property groups: Object.splatline and Scene.splatline.

Each concern defines its own sub-group in its own module; this one only nests them.
"""
import bpy

from . import (display as display_props, dynamic as dynamic_props, effect as effect_props,
               look as look_props, render as render_props, sequence as sequence_props)

_SUBMODULES = (display_props, look_props, effect_props, sequence_props, dynamic_props,
               render_props)


class SplatlineObjectSettings(bpy.types.PropertyGroup):
    display: bpy.props.PointerProperty(type=display_props.DisplaySettings)
    look: bpy.props.PointerProperty(type=look_props.LookSettings)
    effects: bpy.props.CollectionProperty(type=effect_props.Effect)
    active_effect: bpy.props.IntProperty(default=0, min=0)
    sequence: bpy.props.PointerProperty(type=sequence_props.SequenceSettings)
    dynamic: bpy.props.PointerProperty(type=dynamic_props.DynamicSettings)
    # Set on import from the file's own mark (SplatSet.antialiased), overridable; the render
    # engine turns gsplat's opacity compensation on where a flagged object is drawn
    # (RenderOptions.antialiased is one mode per render), and export writes it back.
    antialiased: bpy.props.BoolProperty(
        name="Anti-Aliased Capture", default=False,
        description="The capture was trained with anti-aliasing (gsplat's antialiased mode, "
                    "Mip-Splatting), as its file said: render it with the opacity compensation. "
                    "The compensation is one mode per render, so a frame that draws any flagged "
                    "object applies it to every splat object in it")


class SplatlineSceneSettings(bpy.types.PropertyGroup):
    render: bpy.props.PointerProperty(type=render_props.RenderSettings)


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(
    tuple(cls for module in _SUBMODULES for cls in module.classes)
    + (SplatlineObjectSettings, SplatlineSceneSettings))


def register():
    effect_props.refresh()  # effects added to the table since import get their properties
    _register_classes()
    bpy.types.Object.splatline = bpy.props.PointerProperty(type=SplatlineObjectSettings)
    bpy.types.Scene.splatline = bpy.props.PointerProperty(type=SplatlineSceneSettings)


def unregister():
    del bpy.types.Scene.splatline
    del bpy.types.Object.splatline
    _unregister_classes()
