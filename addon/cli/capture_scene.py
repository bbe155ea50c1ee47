"""A scene for a bare capture: the splat file imported as the UI imports it, plus a camera.

Shared by `render CAPTURE` (which then renders it exactly as it renders a .blend) and
`import` (which adds the camera when the scene has none, so import-then-render works).
Both scenes show the capture's own colours (Standard view transform, `use_capture_colours`).
--camera is "orbit" (default), "front", or a camera-track JSON (camtrack.py's shapes).
"""
from __future__ import annotations

import os

from . import UserError

CAMERA_MODES = ("orbit", "front")
DEFAULT_ORBIT_FRAMES = 120  # five seconds at 24 fps: one slow turn
CAMERA_HELP = ("orbit (default: one turn round the capture over the frame range), front (a still "
               "view from the capture's front), or a camera track: a SuperSplat settings.json, an "
               ".ssproj or its document.json, or {frameRate, frames: [{position, target, fov, up}]}")


def is_blend(path) -> bool:
    """A .blend by its extension or its header (plain .blend files start with BLENDER)."""
    if os.fspath(path).lower().endswith(".blend"):
        return True
    try:
        with open(path, "rb") as f:
            return f.read(7) == b"BLENDER"
    except OSError:
        return False


def load_camera_arg(text):
    """'orbit', 'front' or a CameraTrack read from the file (errors name the file)."""
    if text is None or text.lower() in CAMERA_MODES:
        return (text or "orbit").lower()
    from ..core.camtrack import read_track

    return read_track(text)  # SplatFormatError: one line naming the file


def frame_range(camera, frames=None) -> tuple[int, int]:
    """--frames if given, else what the camera needs: the track's span from frame 1, one
    frame for a front still, DEFAULT_ORBIT_FRAMES for an orbit."""
    if frames is not None:
        return frames
    if camera == "front":
        return 1, 1
    if camera == "orbit":
        return 1, DEFAULT_ORBIT_FRAMES
    return 1, 1 + camera.last_frame


def use_capture_colours(scene) -> None:
    """Colour management that shows the capture's own colours: the Standard view transform
    (scene-linear back to display sRGB, the inverse of the engine's conversion), no look,
    exposure 0, gamma 1. Blender's default, AgX, tone-maps them: highlights top out near
    214/255 and the frame is darker and less saturated than the capture (issue 27)."""
    view = scene.view_settings
    view.view_transform = "Standard"
    view.look = "None"
    view.exposure = 0.0
    view.gamma = 1.0


def add_camera(bpy, objects, camera, frames=None) -> None:
    """Key `camera` (a mode or a CameraTrack) on the scene, framing `objects` (splat
    objects; a track is tied to the first one's frame). frames: (start, end) or None."""
    from ..blender.data import capture_camera

    scene = bpy.context.scene
    if isinstance(camera, str):  # an orbit turns once over the range it is given, or the scene's
        start, end = frames or (scene.frame_start, scene.frame_end)
        capture_camera.add_framing_camera(bpy.context, objects, camera, start, end)
        return
    fps = camera.frame_rate  # Blender keeps an integer rate and a divisor
    scene.render.fps = max(1, round(fps))
    scene.render.fps_base = scene.render.fps / fps
    if frames is None:  # the scene plays the whole track
        scene.frame_end = scene.frame_start + camera.last_frame
    capture_camera.add_track_camera(bpy.context, camera, objects[0] if objects else None,
                                    scene.frame_start)


def build(bpy, path, camera, frames=None):
    """Import `path` into the (empty) scene, add the camera; returns the scene."""
    from ..blender.data.files import import_file
    from ..core.errors import SplatFormatError

    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = frame_range(camera, frames)
    try:
        obj = import_file(bpy.context, path)
    except OSError as exc:
        raise SplatFormatError(path, exc.strerror or str(exc)) from None
    scene.render.film_transparent = True  # a bare capture: alpha is the subject's coverage
    use_capture_colours(scene)
    try:
        add_camera(bpy, [obj], camera, frames)
    except ValueError as exc:
        raise UserError(f"{path}: cannot frame the capture: {exc}") from None
    return scene
