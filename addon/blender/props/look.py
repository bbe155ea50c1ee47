"""LookSettings (Object.splatline.look): object-level look, all animatable.

Colour and size/opacity multipliers become RenderItem fields (no per-splat work); the crop
box and sphere become per-splat opacity (core/look.py). Values are in object (data) space.
"""
import math

import bpy
from bpy.props import BoolProperty, FloatProperty, FloatVectorProperty, IntProperty


def tag_eval(self, _context):
    # A Python-side change does not reach the evaluated copy by itself. Tag lightly
    # ('TIME'): the object re-syncs without a geometry update, so the base-splat cache holds.
    self.id_data.update_tag(refresh={"TIME"})


def _crop_props(prefix, what):
    return {
        f"use_{prefix}": BoolProperty(name=f"Crop {what}", default=False, update=tag_eval,
                                      description=f"Hide splats outside a {what.lower()} (object space)"),
        f"{prefix}_center": FloatVectorProperty(name="Center", size=3, subtype="TRANSLATION",
                                                unit="LENGTH", update=tag_eval),
        f"{prefix}_softness": FloatProperty(name="Softness", default=0.0, min=0.0, soft_max=2.0,
                                            unit="LENGTH", update=tag_eval,
                                            description="Fade width just inside the boundary"),
        f"{prefix}_invert": BoolProperty(name="Invert", default=False, update=tag_eval,
                                         description="Keep the outside instead"),
    }


class LookSettings(bpy.types.PropertyGroup):
    visible: BoolProperty(name="Show", default=True, update=tag_eval,
                          description="Draw and render this object's splats. Untick (rather than "
                                      "hiding the object) for a morph target that should not show: "
                                      "a hidden object is not evaluated by the render, so its "
                                      "animation would not follow")
    opacity: FloatProperty(name="Opacity", default=1.0, min=0.0, soft_max=1.0, max=10.0,
                           update=tag_eval, description="Multiplies every splat's opacity")
    size: FloatProperty(name="Splat Size", default=1.0, min=0.0, soft_max=4.0, update=tag_eval,
                        description="Multiplies every splat's scale (not the centres)")
    tint: FloatVectorProperty(name="Tint", size=3, subtype="COLOR", default=(1.0, 1.0, 1.0),
                              min=0.0, soft_max=1.0, update=tag_eval,
                              description="Multiplies the colour per channel")
    exposure: FloatProperty(name="Exposure", default=0.0, soft_min=-4.0, soft_max=4.0,
                            min=-16.0, max=16.0, update=tag_eval,
                            description="Stops on the display-referred colour (x 2^exposure)")
    saturation: FloatProperty(name="Saturation", default=1.0, min=0.0, soft_max=2.0, max=10.0,
                              update=tag_eval, description="0 = grey (same luma), 1 = unchanged")
    hue: FloatProperty(name="Hue Shift", default=0.0, subtype="ANGLE", soft_min=-math.pi,
                       soft_max=math.pi, update=tag_eval,
                       description="Turns the chroma about the grey axis, keeping luma")
    lighting: FloatProperty(name="Lighting", default=0.0, min=0.0, max=1.0, subtype="FACTOR",
                            update=tag_eval,
                            description="How much the scene's lights and World light the splats "
                                        "(their colour as albedo; Lambert, Cycles' units; meshes "
                                        "and the splats cast shadows). 0: as captured. Splatline's "
                                        "engine and viewport; Blender's own engines do not light splats")
    max_sh_degree: IntProperty(name="Max SH Degree", default=3, min=0, max=3, update=tag_eval,
                               description="Ignore spherical-harmonic bands above this degree")
    __annotations__.update(_crop_props("crop_box", "Box"))
    crop_box_size: FloatVectorProperty(name="Size", size=3, subtype="XYZ", unit="LENGTH",
                                       default=(2.0, 2.0, 2.0), min=0.0, update=tag_eval)
    __annotations__.update(_crop_props("crop_sphere", "Sphere"))
    crop_sphere_radius: FloatProperty(name="Radius", default=1.0, min=0.0, unit="LENGTH",
                                      update=tag_eval)


classes = (LookSettings,)
