"""Effect (an item of Object.splatline.effects): one entry of the ordered effect stack.

One PropertyGroup for every effect type: `type` picks the kernel, the panel shows only the
fields that type uses (FIELDS). Everything numeric is animatable (keyframes, drivers).
"""
import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, FloatVectorProperty,
                       IntProperty, PointerProperty)

from ..data.pointcloud import is_splat_object
from .look import tag_eval

TYPES = (
    ("REVEAL", "Reveal/Dissolve", "A plane, sphere or noise threshold sweeps the splats in or out", "MOD_BUILD", 0),
    ("DISPLACE", "Displace", "Seeded smooth noise displacement, continuous in time", "MOD_NOISE", 1),
    ("EXPLODE", "Explode/Scatter", "Splats fly away from a centre or along a direction", "MOD_EXPLODE", 2),
    ("TWIST", "Twist/Swirl", "Rotate splats about an axis by height or radius", "MOD_SIMPLEDEFORM", 3),
    ("GRADE", "Colour Grade", "A colour gradient by height, distance or noise", "COLOR", 4),
    ("MORPH", "Morph", "Blend towards another splat object", "SHAPEKEY_DATA", 5),
)

# Fields the panel shows per type (besides enabled, amount, gizmo).
FIELDS = {
    "REVEAL": ("reveal_shape", "progress", "edge_width", "invert", "shrink", "glow_color",
               "glow_strength", "frequency", "seed"),
    "DISPLACE": ("amplitude", "frequency", "speed", "seed"),
    "EXPLODE": ("explode_mode", "strength", "spread", "spin", "gravity", "start_frame", "fade", "seed"),
    "TWIST": ("twist", "swirl", "swirl_radius"),
    "GRADE": ("grade_field", "grade_mode", "color_a", "color_b", "use_color_mid", "color_mid",
              "mid_position", "range_low", "range_high", "frequency", "seed"),
    "MORPH": ("target",),
}


def _is_empty(_self, obj):
    return obj.type == "EMPTY"


def _is_other_splat_object(self, obj):
    return obj is not self.id_data and is_splat_object(obj)


def _color(name, default):
    return FloatVectorProperty(name=name, size=3, subtype="COLOR", default=default, min=0.0,
                               soft_max=1.0, update=tag_eval)


class Effect(bpy.types.PropertyGroup):
    type: EnumProperty(name="Type", items=TYPES, default="REVEAL", update=tag_eval)
    enabled: BoolProperty(name="Enabled", default=True, update=tag_eval)
    amount: FloatProperty(name="Blend", default=1.0, min=0.0, max=1.0, subtype="FACTOR",
                          update=tag_eval, description="How much of the effect (Morph: the morph factor)")
    gizmo: PointerProperty(name="Gizmo", type=bpy.types.Object, poll=_is_empty, update=tag_eval,
                           description="Empty whose transform places the plane/sphere/centre/axis "
                                       "(default: world-aligned at the object's origin)")
    seed: IntProperty(name="Seed", default=0, min=0, update=tag_eval)
    frequency: FloatProperty(name="Frequency", default=1.0, min=0.0, soft_max=20.0, update=tag_eval,
                             description="Noise cells per gizmo unit")
    # reveal / dissolve
    reveal_shape: EnumProperty(name="Shape", update=tag_eval, items=(
        ("PLANE", "Plane", "Height along the gizmo's Z"), ("SPHERE", "Sphere", "Distance from the gizmo"),
        ("NOISE", "Noise", "Noise value 0..1")))
    progress: FloatProperty(name="Progress", default=0.0, soft_min=-5.0, soft_max=5.0, update=tag_eval,
                            description="Threshold: splats with a field value below it are shown")
    edge_width: FloatProperty(name="Edge Width", default=0.1, min=0.0, soft_max=2.0, update=tag_eval)
    invert: BoolProperty(name="Invert (Dissolve)", default=False, update=tag_eval)
    shrink: FloatProperty(name="Shrink", default=1.0, min=0.0, max=1.0, subtype="FACTOR", update=tag_eval)
    glow_color: _color("Glow Colour", (1.0, 0.45, 0.1))
    glow_strength: FloatProperty(name="Glow", default=0.0, min=0.0, soft_max=4.0, update=tag_eval)
    # displace
    amplitude: FloatProperty(name="Amplitude", default=0.1, soft_min=0.0, soft_max=2.0,
                             unit="LENGTH", update=tag_eval)
    speed: FloatProperty(name="Speed", default=0.5, soft_min=-5.0, soft_max=5.0, update=tag_eval,
                         description="Noise cells per second the field drifts")
    # explode / scatter
    explode_mode: EnumProperty(name="Mode", update=tag_eval, items=(
        ("CENTER", "From Centre", "Away from the gizmo's origin"),
        ("DIRECTION", "Direction", "Along the gizmo's Z")))
    strength: FloatProperty(name="Speed", default=1.0, soft_min=0.0, soft_max=10.0, update=tag_eval,
                            description="Object units per second")
    spread: FloatProperty(name="Spread", default=0.3, min=0.0, soft_max=3.0, update=tag_eval)
    spin: FloatProperty(name="Spin", default=0.0, soft_min=-20.0, soft_max=20.0, update=tag_eval,
                        description="Radians per second about a random axis")
    gravity: FloatProperty(name="Gravity", default=0.0, soft_min=-20.0, soft_max=20.0, update=tag_eval,
                           description="Units per second squared along the gizmo's -Z")
    start_frame: FloatProperty(name="Start Frame", default=1.0, update=tag_eval)
    fade: FloatProperty(name="Fade", default=0.0, min=0.0, soft_max=5.0, update=tag_eval,
                        description="Opacity decay per second after the start")
    # twist / swirl
    twist: FloatProperty(name="Twist", default=0.5, subtype="ANGLE", update=tag_eval,
                         description="Angle per unit of height along the gizmo's Z")
    swirl: FloatProperty(name="Swirl", default=0.0, subtype="ANGLE", update=tag_eval,
                         description="Angle at the axis, falling off with distance")
    swirl_radius: FloatProperty(name="Swirl Radius", default=1.0, min=0.0, update=tag_eval)
    # colour grade
    grade_field: EnumProperty(name="Field", update=tag_eval, items=(
        ("HEIGHT", "Height", "Along the gizmo's Z"), ("DISTANCE", "Distance", "From the gizmo"),
        ("NOISE", "Noise", "Noise value 0..1")))
    grade_mode: EnumProperty(name="Blend Mode", update=tag_eval, items=(
        ("MIX", "Mix", ""), ("MULTIPLY", "Multiply", ""), ("ADD", "Add", "")))
    color_a: _color("Low Colour", (0.1, 0.2, 1.0))
    color_b: _color("High Colour", (1.0, 0.4, 0.1))
    use_color_mid: BoolProperty(name="Middle Colour", default=False, update=tag_eval)
    color_mid: _color("Middle Colour", (1.0, 1.0, 1.0))
    mid_position: FloatProperty(name="Middle At", default=0.5, min=0.0, max=1.0, subtype="FACTOR",
                                update=tag_eval)
    range_low: FloatProperty(name="Low", default=0.0, update=tag_eval, description="Field value of the low colour")
    range_high: FloatProperty(name="High", default=1.0, update=tag_eval, description="Field value of the high colour")
    # morph
    target: PointerProperty(name="Target", type=bpy.types.Object, poll=_is_other_splat_object,
                            update=tag_eval,
                            description="Splat object to morph into (its own data, not its effects). "
                                        "To keep it from showing, untick its Look > Show rather than "
                                        "hiding it, so the render still evaluates its animation")


classes = (Effect,)
