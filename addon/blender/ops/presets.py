"""Render-output presets in Blender's preset format, bundled in presets/ and user-extendable.

Bundled presets live in the extension's presets/render/; presets the user adds go where
Blender keeps its own (SCRIPTS/presets/splatline/render), so both appear in one menu and
Blender's `script.execute_preset` applies either. The command line runs the same files.
"""
from __future__ import annotations

import pathlib

import bpy
from bl_operators.presets import AddPresetBase

from ..compat import has_media_type

BUNDLED = pathlib.Path(__file__).resolve().parents[3] / "presets"  # <root>/addon/blender/ops/presets.py
RENDER_SUBDIR = "splatline/render"


def preset_dirs(kind: str = "render") -> list[pathlib.Path]:
    """Bundled folder first, then Blender's user preset folders for this kind."""
    dirs = [BUNDLED / kind]
    dirs += [pathlib.Path(p) for p in bpy.utils.preset_paths(f"splatline/{kind}")]
    return [d for d in dirs if d.is_dir()]


def list_presets(kind: str = "render", ext: str = ".py") -> dict[str, pathlib.Path]:
    """Preset name (file stem) -> path; a user preset shadows a bundled one of the same name."""
    found = {}
    for folder in preset_dirs(kind):
        for path in sorted(folder.glob(f"*{ext}")):
            found[path.stem] = path
    return found


def find_preset(name: str, kind: str = "render", ext: str = ".py") -> pathlib.Path:
    """A preset by file stem or display name, case-insensitive; KeyError lists the choices."""
    presets = list_presets(kind, ext)
    wanted = bpy.path.display_name_to_filepath(name).lower().replace(" ", "_")
    for stem, path in presets.items():
        if stem.lower() == wanted:
            return path
    raise KeyError(f"no {kind} preset {name!r}; choose from: {', '.join(sorted(presets))}")


def apply_render_preset(name_or_path) -> pathlib.Path:
    """Run a render preset against bpy.context.scene, as Blender's preset menu does."""
    path = pathlib.Path(name_or_path)
    if not path.is_file():
        path = find_preset(str(name_or_path), "render")
    bpy.ops.script.execute_preset(filepath=str(path), menu_idname=SPLATLINE_MT_render_presets.bl_idname)
    return path


def _draw_preset_menu(menu, subdir_kind: str):
    menu.path_menu([str(d) for d in preset_dirs(subdir_kind)], "script.execute_preset",
                   props_default={"menu_idname": menu.bl_idname},
                   filter_ext=lambda ext: ext.lower() == ".py")


class SPLATLINE_MT_render_presets(bpy.types.Menu):
    bl_idname = "SPLATLINE_MT_render_presets"
    bl_label = "Splatline Output Presets"
    preset_subdir = RENDER_SUBDIR
    preset_operator = "script.execute_preset"

    def draw(self, context):
        _draw_preset_menu(self, "render")


class SPLATLINE_OT_render_preset_add(AddPresetBase, bpy.types.Operator):
    """Save the current output format, resolution and Splatline quality settings as a preset"""
    bl_idname = "splatline.render_preset_add"
    bl_label = "Add Splatline Output Preset"
    preset_menu = "SPLATLINE_MT_render_presets"
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
        name = SPLATLINE_MT_render_presets.bl_label
    if (bpy.utils.preset_find(name, RENDER_SUBDIR)
            or bpy.utils.preset_find(name, RENDER_SUBDIR, display_name=True)):
        return None
    stems = [path.stem for path in (BUNDLED / "render").glob("*.py")]
    bundled = {n.lower() for s in stems for n in (s, bpy.path.display_name(s, title_case=False))}
    if name.lower() in bundled:
        return f"{name}: a bundled output preset, which can't be removed"
    return f"{name}: no saved output preset of that name to remove (choose one from the menu first)"


class SPLATLINE_PT_output_presets(bpy.types.Panel):
    """Output presets beside Blender's own output settings, for the Splatline engine."""
    bl_label = "Splatline Output"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "output"
    COMPAT_ENGINES = {"SPLATLINE"}

    @classmethod
    def poll(cls, context):
        return context.scene.render.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        row = self.layout.row(align=True)
        row.menu(SPLATLINE_MT_render_presets.__name__, text=SPLATLINE_MT_render_presets.bl_label)
        row.operator(SPLATLINE_OT_render_preset_add.bl_idname, text="", icon="ADD")
        remove = row.operator(SPLATLINE_OT_render_preset_add.bl_idname, text="", icon="REMOVE")
        remove.remove_active = True


classes = (SPLATLINE_MT_render_presets, SPLATLINE_OT_render_preset_add, SPLATLINE_PT_output_presets)


register, unregister = bpy.utils.register_classes_factory(classes)
