"""Preset files in Blender's preset format: where they are, finding one by name, and running
a render preset, for the operators, menus, command line and demo alike.

Bundled presets live in the extension's presets/<kind>/; presets the user adds go where
Blender keeps its own (SCRIPTS/presets/splatline/<kind>), so both appear in one menu and
Blender's `script.execute_preset` applies either. The command line runs the same files.
"""
from __future__ import annotations

import pathlib

import bpy

BUNDLED = pathlib.Path(__file__).resolve().parents[3] / "presets"  # <root>/addon/blender/data/presets.py
RENDER_SUBDIR = "splatline/render"
# The menu that lists render presets (ui/presets.py): execute_preset names it so that the
# menu's label shows the preset last chosen, as Blender's own preset menus do.
RENDER_MENU = "SPLATLINE_MT_render_presets"


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
    bpy.ops.script.execute_preset(filepath=str(path), menu_idname=RENDER_MENU)
    return path
