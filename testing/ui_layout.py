"""A stand-in for Blender's UILayout that records what a panel's draw() asks for, and the
check that every name it recorded exists in the running Blender (background mode has no UI to
draw into; in the UI a wrong name only prints to the console)."""
from __future__ import annotations

from types import SimpleNamespace


class RecordingLayout:
    """Stands in for bpy.types.UILayout: sub-layouts share one record."""

    def __init__(self, record=None):
        self.record = record if record is not None else []
        self.use_property_split = self.use_property_decorate = False

    def _sub(self, *_args, **_kwargs):
        return RecordingLayout(self.record)

    row = column = box = _sub

    def separator(self, *_args, **_kwargs):
        pass

    def label(self, text="", icon="NONE", **_kwargs):
        self.record.append(("label", text, icon))

    def prop(self, data, name, icon="NONE", **_kwargs):
        self.record.append(("prop", (data, name), icon))

    def operator(self, idname, icon="NONE", **_kwargs):
        self.record.append(("operator", idname, icon))
        return SimpleNamespace()  # operator properties set by the panel land here

    def operator_menu_enum(self, idname, prop, icon="NONE", **_kwargs):
        self.record.append(("operator", idname, icon))

    def menu(self, idname, icon="NONE", **_kwargs):
        self.record.append(("menu", idname, icon))


def check_names_exist(bpy, record):
    icons = bpy.types.UILayout.bl_rna.functions["prop"].parameters["icon"].enum_items.keys()
    for kind, what, icon in record:
        assert icon in icons, icon
        if kind == "prop":
            data, name = what
            assert name in data.bl_rna.properties, (data, name)
        elif kind == "operator":
            module, name = what.split(".")
            getattr(getattr(bpy.ops, module), name).get_rna_type()  # raises when unknown
        elif kind == "menu":
            assert hasattr(bpy.types, what), what
