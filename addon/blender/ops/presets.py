"""Saving and removing render-output presets (Blender's AddPresetBase): the + and - beside the
preset menu. The preset files, and running one, are data/presets.py's; the menu and the
Output panel are ui/presets.py's.
"""
from __future__ import annotations

import bpy
from bl_operators.presets import AddPresetBase

from ..compat import has_media_type
from ..data.presets import BUNDLED, RENDER_MENU, RENDER_SUBDIR


class SPLATLINE_OT_render_preset_add(AddPresetBase, bpy.types.Operator):
    """Save the current output format, resolution and Splatline quality settings as a preset"""
    bl_idname = "splatline.render_preset_add"
    bl_label = "Add Splatline Output Preset"
    preset_menu = RENDER_MENU
    preset_subdir = RENDER_SUBDIR
    preset_defines = ["scene = bpy.context.scene", "image = scene.render.image_settings"]
    # 4.5 has no image.media_type (compat.has_media_type): only save it where it exists.
    preset_values = [
        *(["image.media_type"] if has_media_type(bpy.types.ImageFormatSettings) else []),
        "image.file_format", "image.color_mode", "image.color_depth",
        "image.exr_codec", "scene.render.resolution_percentage",
        "scene.render.ffmpeg.format", "scene.render.ffmpeg.codec",
        # The codec settings the bundled video presets choose (prores_422.py, h264_mp4.py):
        # without them a saved ProRes preset would reload as whatever profile was last set.
        "scene.render.ffmpeg.ffmpeg_prores_profile", "scene.render.ffmpeg.constant_rate_factor",
        "scene.render.ffmpeg.ffmpeg_preset", "scene.render.ffmpeg.audio_codec",
        "scene.splatline.render.key_bits", "scene.splatline.render.antialiased",
        "scene.splatline.render.capped_extent",
    ]

    def execute(self, context):
        # AddPresetBase only finds presets in Blender's preset folders, so removing a bundled
        # one (or with none chosen yet) cancels without a word: say why instead.
        if self.remove_active or self.remove_name:
            problem = _removal_problem(self.name, self.remove_active)
            if problem:
                self.report({"ERROR"}, problem)
                return {"CANCELLED"}
        return super().execute(context)


def _removal_problem(name: str, active: bool) -> str | None:
    """Why the render preset that AddPresetBase would remove can't be, or None if it can."""
    if active:  # the menu's label is the last preset chosen, as AddPresetBase reads it
        name = getattr(bpy.types, RENDER_MENU).bl_label
    if (bpy.utils.preset_find(name, RENDER_SUBDIR)
            or bpy.utils.preset_find(name, RENDER_SUBDIR, display_name=True)):
        return None
    stems = [path.stem for path in (BUNDLED / "render").glob("*.py")]
    bundled = {n.lower() for s in stems for n in (s, bpy.path.display_name(s, title_case=False))}
    if name.lower() in bundled:
        return f"{name}: a bundled output preset, which can't be removed"
    return f"{name}: no saved output preset of that name to remove (choose one from the menu first)"


classes = (SPLATLINE_OT_render_preset_add,)


register, unregister = bpy.utils.register_classes_factory(classes)
