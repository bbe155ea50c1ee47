"""File > Import > Splat Camera Track: a SuperSplat / splat-transform camera path as a keyed camera.

The track's world is the capture's (core/camtrack.py): it is tied to the active splat object,
or the first one in the scene, so the camera follows the capture wherever it was moved.
"""
from __future__ import annotations

import bpy
from bpy.props import BoolProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ImportHelper

from ...core.camtrack import read_track
from ...core.errors import SplatFormatError
from ..data.capture_camera import add_track_camera, set_frame_rate
from ..data.sources import is_splat_object
from ..registration import classes_and_menus


def _reference(context):
    """The splat object the track's coordinates belong to (None: an unmoved RDF capture)."""
    active = context.active_object
    if is_splat_object(active, with_splat_data=True):
        return active
    return next((o for o in context.scene.objects if is_splat_object(o, with_splat_data=True)), None)


class IMPORT_SCENE_OT_splatline_camera_track(bpy.types.Operator, ImportHelper):
    """Import a SuperSplat or splat-transform camera track as a keyframed camera"""

    bl_idname = "import_scene.splatline_camera_track"
    bl_label = "Splat Camera Track (.json, .ssproj)"
    bl_options = {"REGISTER", "UNDO"}

    filter_glob: StringProperty(default="*.json;*.ssproj", options={"HIDDEN"})
    start_frame: IntProperty(name="Start Frame", default=1,
                             description="Scene frame the track's first frame lands on")
    set_scene_range: BoolProperty(name="Set Frame Range", default=True,
                                  description="Fit the scene's frame range and frame rate to the track")
    make_active: BoolProperty(name="Set Active Camera", default=True,
                              description="Render through the imported camera")

    def execute(self, context):
        try:
            track = read_track(self.filepath)
        except SplatFormatError as exc:  # bad input: one line, nothing made
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        scene = context.scene
        previous = scene.camera
        camera = add_track_camera(context, track, _reference(context), self.start_frame,
                                  name=bpy.path.display_name_from_filepath(self.filepath) or "Track")
        if not self.make_active:
            scene.camera = previous
        if self.set_scene_range:
            scene.frame_start, scene.frame_end = self.start_frame, self.start_frame + track.last_frame
            set_frame_rate(scene, track.frame_rate)
        self.report({"INFO"}, f"{camera.name}: {len(track.keys)} keys from {track.shape}")
        return {"FINISHED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        for name in ("start_frame", "set_scene_range", "make_active"):
            layout.prop(self, name)


def _menu_import(self, context):
    self.layout.operator(IMPORT_SCENE_OT_splatline_camera_track.bl_idname,
                         text="Splat Camera Track (.json, .ssproj)")


register, unregister = classes_and_menus((IMPORT_SCENE_OT_splatline_camera_track,),
                                         (("TOPBAR_MT_file_import", _menu_import),))
