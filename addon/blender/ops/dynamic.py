"""File > Import > Dynamic Splat Capture: a 4D capture (Spacetime Gaussians PLY, linear-motion
PLY, .splatv, .4dgs) as one object that plays on the timeline. Several Spacetime segment
files picked together play in order as one object."""
from __future__ import annotations

import bpy
from bpy.props import CollectionProperty, EnumProperty, FloatProperty, StringProperty
from bpy_extras.io_utils import ImportHelper

from ...core.dynamic import timeline
from ...core.errors import SplatFormatError
from ..data.dynamic_files import import_dynamic
from .io import picked_paths
from ..registration import classes_and_menus

_MODES = [(timeline.HOLD, "Hold", "Hold the first and last moments outside the capture's range"),
          (timeline.LOOP, "Loop", "Repeat the capture"),
          (timeline.PING_PONG, "Ping-Pong", "Play forwards, then backwards, and repeat")]


class IMPORT_SCENE_OT_splatline_dynamic(bpy.types.Operator, ImportHelper):
    """Import a dynamic (4D) Gaussian splat capture that plays on the timeline"""

    bl_idname = "import_scene.splatline_dynamic"
    bl_label = "Dynamic Splat Capture (.ply, .splatv, .4dgs)"
    bl_options = {"REGISTER", "UNDO"}

    filter_glob: StringProperty(default="*.ply;*.splatv;*.4dgs", options={"HIDDEN"})
    directory: StringProperty(subtype="DIR_PATH", options={"SKIP_SAVE", "HIDDEN"})
    files: CollectionProperty(type=bpy.types.OperatorFileListElement, options={"SKIP_SAVE", "HIDDEN"})
    frames_per_unit: FloatProperty(
        name="Frames per Unit", default=0.0, min=0.0, soft_max=1000.0,
        description="Scene frames one unit of the capture's time spans (0: the file's rate, "
                    "else real time for captures in seconds and 50 frames a Spacetime segment)")
    mode: EnumProperty(name="Outside Range", items=_MODES, default=timeline.HOLD)

    def execute(self, context):
        paths = sorted(picked_paths(self))  # segments play in their names' order
        if not paths:
            self.report({"ERROR"}, "no file given")
            return {"CANCELLED"}
        try:
            obj = import_dynamic(context, paths, frames_per_unit=self.frames_per_unit or None)
        except SplatFormatError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        except (OSError, MemoryError) as exc:
            self.report({"ERROR"}, f"{paths[0]}: {exc.strerror if isinstance(exc, OSError) else 'out of memory'}")
            return {"CANCELLED"}
        obj.splatline.dynamic.mode = self.mode
        dynamic = obj.splatline.dynamic
        self.report({"INFO"}, f"imported {obj.name}: {len(obj.data.points)} dynamic splats, "
                              f"{dynamic.model}, {len(paths)} file(s)")
        return {"FINISHED"}


def _menu_import(self, _context):
    self.layout.operator(IMPORT_SCENE_OT_splatline_dynamic.bl_idname, text="Dynamic Splat Capture (.ply, .splatv, .4dgs)")


register, unregister = classes_and_menus(
    (IMPORT_SCENE_OT_splatline_dynamic,), (("TOPBAR_MT_file_import", _menu_import),))
