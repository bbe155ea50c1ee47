"""Motion blur from Blender's own settings: which sub-frame times a frame averages.

Output > Motion Blur: scene.render.use_motion_blur, motion_blur_shutter (frames) and
motion_blur_position (START, CENTER, END; read where RNA has it, else CENTER, Blender's
default). The sample count is Splatline's (Scene.splatline.render.motion_blur_samples).
The engine evaluates the scene at each time through RenderEngine.frame_set (transforms,
effects, look and the camera all follow) and averages the frames (core/shutter.py).
"""
from __future__ import annotations

from ...core import shutter

DEFAULT_POSITION = "CENTER"


def shutter_position(render) -> str:
    if "motion_blur_position" in render.bl_rna.properties:
        return render.motion_blur_position
    return DEFAULT_POSITION


def sub_frame_times(scene, frame: int) -> list[float]:
    """The scene times `frame` averages; [] where motion blur is off (or one sample,
    or a shutter that does not open)."""
    r = scene.render
    samples = int(scene.splatline.render.motion_blur_samples)
    if not r.use_motion_blur or samples < 2 or not r.motion_blur_shutter > 0.0:
        return []
    return shutter.sub_frame_times(frame, float(r.motion_blur_shutter), shutter_position(r),
                                   samples)
