"""Effect (an item of Object.splatline.effects): one entry of the ordered effect stack.

One PropertyGroup for every effect type, built from the effect table (core.effects.registry)
when it registers: `type` picks the kernel, and each kind's fields become properties; the
panel shows only the fields the type uses (FIELDS). Everything numeric is animatable
(keyframes, drivers).
"""
import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, FloatVectorProperty,
                       IntProperty, PointerProperty)

from ...core.effects import registry
from ..data.sources import is_splat_object
from .look import tag_eval

# (id, label, description, icon, number) per effect, and the field names the panel shows
# per type (besides enabled, amount, gizmo). Filled from the table by refresh(), in place,
# so the operators' menu, which holds this very list, offers every registered kind.
TYPES: list = []
FIELDS: dict = {}


def _is_empty(_self, obj):
    return obj.type == "EMPTY"


def _is_other_splat_object(self, obj):
    return obj is not self.id_data and is_splat_object(obj)


def _property(f):
    """The bpy property of one core Field (every one re-evaluates the object when set)."""
    common = dict(name=f.label, description=f.description, update=tag_eval, **f.options)
    if f.type == "FLOAT":
        return FloatProperty(default=f.default, **common)
    if f.type == "INT":
        return IntProperty(default=f.default, **common)
    if f.type == "BOOL":
        return BoolProperty(default=f.default, **common)
    if f.type == "ENUM":
        default = {} if f.default is None else {"default": f.default}
        return EnumProperty(items=f.items, **default, **common)
    if f.type == "COLOR":
        return FloatVectorProperty(size=3, subtype="COLOR", default=f.default, min=0.0,
                                   soft_max=1.0, **common)
    return PointerProperty(type=bpy.types.Object, poll=_is_other_splat_object, **common)


def _common_properties() -> dict:
    return {
        "type": EnumProperty(name="Type", items=TYPES, default="REVEAL", update=tag_eval),
        "enabled": BoolProperty(name="Enabled", default=True, update=tag_eval),
        "amount": FloatProperty(name="Blend", default=1.0, min=0.0, max=1.0, subtype="FACTOR",
                                update=tag_eval,
                                description="How much of the effect (Morph: the morph factor)"),
        "gizmo": PointerProperty(name="Gizmo", type=bpy.types.Object, poll=_is_empty, update=tag_eval,
                                 description="Empty whose transform places the plane/sphere/centre/axis "
                                             "(default: world-aligned at the object's origin)"),
    }


# Its properties are set by refresh(), from the effect table, before it registers (a comment,
# not a docstring: Blender would show one as the group's description).
class Effect(bpy.types.PropertyGroup):
    pass


def refresh() -> None:
    """Rebuild TYPES, FIELDS and Effect's properties from the table (call before registering)."""
    kinds = list(registry.KINDS.values())
    TYPES[:] = [(k.id, k.label, k.description, k.icon, k.number) for k in kinds]
    FIELDS.clear()
    FIELDS.update({k.id: tuple(f.name for f in k.fields) for k in kinds})
    Effect.__annotations__ = {**_common_properties(),
                              **{f.name: _property(f) for f in registry.all_fields()}}


refresh()


classes = (Effect,)
