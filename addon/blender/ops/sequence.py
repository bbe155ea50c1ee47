"""File > Import > Splat Sequence, File > Export > Evaluated Splats and the bake operator
(the frame cache and its handlers are data/sequence_source.py's; the Object-properties
panel of a sequence is ui/object_panels.py's)."""
from __future__ import annotations

import os

import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

from ...core.errors import SplatFormatError
from ..data.sequences import (ALIGN_FILE_NUMBERS, ALIGN_SCENE_START, import_sequence,
                              remap_directories, restore_directories)
from ..data.sources import is_splat_object
from ..evaluate.bake import bake_frames, export_evaluated
from ..props.sequence import _LOOP_ITEMS
from ..registration import classes_and_menus
from .io import DATA_AXES_ITEMS
from .reporting import finish_reporting


def _splat_object(context):
    obj = context.active_object
    return obj if is_splat_object(obj, with_splat_data=True) else None


class IMPORT_SCENE_OT_splatline_sequence(bpy.types.Operator, ImportHelper):
    """Import a folder of numbered splat files as one object that plays them on the timeline"""

    bl_idname = "import_scene.splatline_sequence"
    bl_label = "Splat Sequence"
    bl_options = {"REGISTER", "UNDO"}

    filter_glob: StringProperty(default="*.ply;*.splat;*.spz", options={"HIDDEN"})
    directory: StringProperty(subtype="DIR_PATH", options={"SKIP_SAVE", "HIDDEN"})
    align: EnumProperty(name="Timing", default=ALIGN_FILE_NUMBERS, items=[
        (ALIGN_FILE_NUMBERS, "File Numbers", "File number N shows at scene frame N (as a bake writes them)"),
        (ALIGN_SCENE_START, "Scene Start", "The first file shows at the scene's start frame"),
    ])
    loop_mode: EnumProperty(name="Loop", items=_LOOP_ITEMS, default="HOLD")
    set_scene_range: BoolProperty(name="Set Scene Range", default=False,
                                  description="Set the scene's frame range to the sequence's")

    def execute(self, context):
        # a chosen file names the pattern; a folder alone picks its largest numbered group
        path = self.filepath if os.path.isfile(self.filepath) else (self.directory or self.filepath)

        def load():
            obj = import_sequence(context, path, align=self.align, loop_mode=self.loop_mode,
                                  set_scene_range=self.set_scene_range)
            seq = obj.splatline.sequence
            return f"{obj.name}: {seq.frame_count} frames from {seq.directory}"
        return finish_reporting(self, load, SplatFormatError)


class EXPORT_SCENE_OT_splatline_evaluated(bpy.types.Operator, ExportHelper):
    """Export the active splat object's evaluated splats at this frame (effects and look baked)"""

    bl_idname = "export_scene.splatline_evaluated"
    bl_label = "Evaluated Splats"
    bl_options = {"REGISTER"}

    filename_ext = ".ply"
    check_extension = False  # keep a typed .splat; execute() adds .ply to anything else
    filter_glob: StringProperty(default="*.ply;*.splat", options={"HIDDEN"})
    data_axes: EnumProperty(name="Data Axes", items=DATA_AXES_ITEMS, default="AUTO",
                            description="The axis convention the object's data is in; the file is "
                                        "written in its format's own")

    @classmethod
    def poll(cls, context):
        return _splat_object(context) is not None

    def execute(self, context):
        path = self.filepath
        if os.path.splitext(path)[1].lower() not in (".ply", ".splat"):
            path += ".ply"

        def write():
            axes = None if self.data_axes == "AUTO" else self.data_axes
            export_evaluated(_splat_object(context), context.evaluated_depsgraph_get(), path, axes)
            return f"wrote {path}"
        return finish_reporting(self, write, SplatFormatError)


class SPLATLINE_OT_bake_sequence(bpy.types.Operator):
    """Write the active splat object's evaluated splats for each frame as numbered PLYs (Esc cancels)"""

    bl_idname = "splatline.bake_sequence"
    bl_label = "Bake Splat Sequence"
    bl_options = {"REGISTER"}

    directory: StringProperty(name="Folder", subtype="DIR_PATH")
    frame_start: IntProperty(name="Start", default=1, min=0)
    frame_end: IntProperty(name="End", default=250, min=0)
    prefix: StringProperty(name="Prefix", default="frame_")
    import_result: BoolProperty(name="Import Result", default=False,
                                description="Import the baked frames as a sequence object afterwards")

    _steps = None
    _timer = None

    @classmethod
    def poll(cls, context):
        return _splat_object(context) is not None

    def invoke(self, context, event):
        scene = context.scene
        self.frame_start, self.frame_end = max(scene.frame_start, 0), max(scene.frame_end, 0)
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def _begin(self, context):
        if not self.directory:
            raise ValueError("choose a folder to bake into")
        if self.frame_end < self.frame_start:
            raise ValueError(f"empty frame range {self.frame_start}..{self.frame_end}")
        self._steps = bake_frames(context, _splat_object(context), self.directory,
                                  self.frame_start, self.frame_end, self.prefix)
        self._done = 0
        context.window_manager.progress_begin(0, self.frame_end - self.frame_start + 1)

    def _step(self, context) -> bool:
        """Bake one frame; False when all are written."""
        try:
            next(self._steps)
        except StopIteration:
            return False
        self._done += 1
        context.window_manager.progress_update(self._done)
        return True

    def _finish(self, context, cancelled=False):
        if self._steps is not None:
            self._steps.close()  # restores the scene frame
        context.window_manager.progress_end()
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
            self._timer = None
        what = "cancelled after" if cancelled else "baked"
        self.report({"WARNING" if cancelled else "INFO"}, f"{what} {self._done} frames into {self.directory}")
        if not cancelled and self.import_result:
            path = os.path.join(bpy.path.abspath(self.directory), f"{self.prefix}{str(self.frame_start).zfill(4)}.ply")
            import_sequence(context, path)
        return {"CANCELLED"} if cancelled else {"FINISHED"}

    def execute(self, context):
        try:
            self._begin(context)
        except ValueError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        if context.window is None or bpy.app.background:
            return self._run_all(context)
        # interactive: one frame per timer tick, so the UI stays responsive and Esc works
        self._timer = context.window_manager.event_timer_add(0.001, window=context.window)
        context.window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _run_all(self, context):
        try:
            while self._step(context):
                pass
        except (SplatFormatError, OSError) as exc:
            self.report({"ERROR"}, str(exc))
            self._finish(context, cancelled=True)
            return {"CANCELLED"}
        return self._finish(context)

    def modal(self, context, event):
        if event.type == "ESC":
            return self._finish(context, cancelled=True)
        if event.type != "TIMER":
            return {"RUNNING_MODAL"}
        try:
            if self._step(context):
                return {"RUNNING_MODAL"}
        except (SplatFormatError, OSError) as exc:
            self.report({"ERROR"}, str(exc))
            return self._finish(context, cancelled=True)
        return self._finish(context)


def _menu_import(self, context):
    self.layout.operator(IMPORT_SCENE_OT_splatline_sequence.bl_idname, text="Splat Sequence (.ply, .splat, .spz)")


def _menu_export(self, context):
    self.layout.operator(EXPORT_SCENE_OT_splatline_evaluated.bl_idname, text="Evaluated Splats (.ply, .splat)")
    self.layout.operator(SPLATLINE_OT_bake_sequence.bl_idname, text="Baked Splat Sequence (.ply)")


class _SaveRemap:
    """save_pre makes sequence folders relative to where the .blend is saved; save_post
    puts them back when the save was a copy (the open file did not move)."""

    def __init__(self):
        self.previous = {}

    @bpy.app.handlers.persistent
    def pre(self, filepath, *_args):
        self.previous = remap_directories(filepath) if filepath else {}

    @bpy.app.handlers.persistent
    def post(self, filepath, *_args):
        if self.previous and os.path.abspath(bpy.data.filepath) != os.path.abspath(filepath):
            restore_directories(self.previous)
        self.previous = {}


_save_remap = None


_CLASSES = (IMPORT_SCENE_OT_splatline_sequence, EXPORT_SCENE_OT_splatline_evaluated,
            SPLATLINE_OT_bake_sequence)


_register_classes, _unregister_classes = classes_and_menus(
    _CLASSES, (("TOPBAR_MT_file_import", _menu_import), ("TOPBAR_MT_file_export", _menu_export)))


def register():
    global _save_remap
    _register_classes()
    _save_remap = _SaveRemap()
    bpy.app.handlers.save_pre.append(_save_remap.pre)
    bpy.app.handlers.save_post.append(_save_remap.post)


def unregister():
    global _save_remap
    if _save_remap is not None:
        for handlers, fn in ((bpy.app.handlers.save_pre, _save_remap.pre),
                             (bpy.app.handlers.save_post, _save_remap.post)):
            if fn in handlers:
                handlers.remove(fn)
        _save_remap = None
    _unregister_classes()
