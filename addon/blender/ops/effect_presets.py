"""Effect-preset operators: apply one to the active splat object with one click, save the
object's own stack as a new preset, remove a user preset. The presets themselves (applying,
capturing, where they are saved) are data/effect_presets.py's; the menus are ui/presets.py's."""
from __future__ import annotations

import json
import pathlib

import bpy

from ...core import effect_presets as core
from ..data import effect_presets as library
from ..data.sources import is_splat_object
from ..data.presets import find_preset
from .reporting import finish_reporting


def _os_text(exc: OSError) -> str:
    return f"{exc.filename}: {exc.strerror}" if exc.filename and exc.strerror else str(exc)


def _active_splat_object(context):
    obj = context.active_object
    return obj if is_splat_object(obj) else None


class SPLATLINE_OT_effect_preset_apply(bpy.types.Operator):
    """Add this preset's effects to the active splat object, keyed from the current frame"""
    bl_idname = "splatline.effect_preset_apply"
    bl_label = "Apply Effect Preset"
    bl_options = {"REGISTER", "UNDO"}

    preset: bpy.props.StringProperty(name="Preset", description="Preset name (file stem)")

    @classmethod
    def poll(cls, context):
        return _active_splat_object(context) is not None

    def execute(self, context):
        obj = _active_splat_object(context)
        others = [o for o in context.selected_objects if o is not obj and is_splat_object(o)]
        frame = context.scene.frame_current

        def apply():
            preset = core.load(find_preset(self.preset, "effects", ".json"))
            library.apply_preset(obj, preset, frame, others[0] if others else None)
            return f"{preset.label}: added to {obj.name} at frame {frame}"
        # apply_preset turns bpy's errors into PresetError
        return finish_reporting(self, apply, (KeyError, core.PresetError), library.one_line)


class SPLATLINE_OT_effect_preset_add(bpy.types.Operator):
    """Save the active object's effect stack and its keyframes, relative to the current frame"""
    bl_idname = "splatline.effect_preset_add"
    bl_label = "Save Effect Preset"

    name: bpy.props.StringProperty(name="Name", default="My Effect")

    @classmethod
    def poll(cls, context):
        obj = _active_splat_object(context)
        return obj is not None and len(obj.splatline.effects) > 0

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        obj = _active_splat_object(context)
        if not self.name.strip():
            self.report({"ERROR"}, "an effect preset needs a name")
            return {"CANCELLED"}
        data = library.capture_preset(obj, context.scene.frame_current, self.name)

        def write():
            path = library.user_dir() / (bpy.path.clean_name(self.name.strip()).lower() + ".json")
            path.write_text(json.dumps(data, indent=1))
            return f"saved {path}"
        return _on_user_file(self, write, f"save effect preset {self.name!r}")


class SPLATLINE_OT_effect_preset_remove(bpy.types.Operator):
    """Delete a preset you saved (bundled presets stay)"""
    bl_idname = "splatline.effect_preset_remove"
    bl_label = "Remove Effect Preset"

    preset: bpy.props.StringProperty(name="Preset")

    def execute(self, context):
        def unlink():
            # A bare file stem only: the name must not reach outside the preset folder.
            path = library.user_dir() / f"{pathlib.Path(self.preset).name}.json"
            if not self.preset or path.stem != self.preset or not path.is_file():
                self.report({"ERROR"}, f"{self.preset}: not a user preset (bundled presets can't be removed)")
                return None
            path.unlink()
            return f"removed {path}"
        return _on_user_file(self, unlink, f"remove effect preset {self.preset!r}")


def _on_user_file(op, action, what: str) -> set:
    """finish_reporting for a change to the user preset folder (an OSError: cannot `what`)."""
    return finish_reporting(op, action, OSError, lambda exc: f"cannot {what}: {_os_text(exc)}")


classes = (SPLATLINE_OT_effect_preset_apply, SPLATLINE_OT_effect_preset_add,
           SPLATLINE_OT_effect_preset_remove)


register, unregister = bpy.utils.register_classes_factory(classes)
