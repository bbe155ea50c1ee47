"""A scene for a bare capture: the splat file imported as the UI imports it, plus a camera.

Shared by `render CAPTURE` (which then renders it exactly as it renders a .blend) and
`import` (which adds the camera when the scene has none, so import-then-render works).
Both scenes show the capture's own colours (Standard view transform, `use_capture_colours`).
--camera is a view (framing_options.VIEWS: orbit by default) or a camera-track JSON
(camtrack.py's shapes); the other framing flags arrive as a framing_options.Framing.
"""
from __future__ import annotations

import os

from . import UsageError, UserError
from .framing_options import DEFAULT_FPS, DEFAULT_ORBIT_FRAMES, VIEWS, Framing

CAMERA_MODES = VIEWS


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
    """A view name (VIEWS) or a CameraTrack read from the file (errors name the file). A
    word that is no file and looks like no path is a misspelled view: one line naming them."""
    if text is None or text.lower() in CAMERA_MODES:
        return (text or "orbit").lower()
    if not os.path.exists(text) and os.sep not in text and "." not in text:
        raise UsageError(f"--camera {text}: neither a view ({', '.join(VIEWS)}) nor a file")
    from ..core.camtrack import read_track

    return read_track(text)  # SplatFormatError: one line naming the file


def frame_range(camera, frames=None) -> tuple[int, int]:
    """--frames if given, else what the camera needs: the track's span from frame 1, one
    frame for a still view, DEFAULT_ORBIT_FRAMES for an orbit."""
    if frames is not None:
        return frames
    if camera == "orbit":
        return 1, DEFAULT_ORBIT_FRAMES
    if isinstance(camera, str):
        return 1, 1
    return 1, 1 + camera.last_frame


def seconds_range(camera, options: Framing, frames=None):
    """--frames, or --seconds in frames from 1 at --fps, the track's rate or the default
    24 fps; None when neither is given."""
    if options.seconds is None:
        return frames
    rate = camera.frame_rate if not isinstance(camera, str) else DEFAULT_FPS
    return 1, options.frame_count(rate)


def check_camera_options(camera, options: Framing) -> None:
    """What the flags cannot do with this camera (before Blender starts)."""
    if options.fps is not None and not isinstance(camera, str):
        raise UsageError(f"--fps {options.fps:g}: a camera track keeps its own frame rate "
                         f"({camera.frame_rate:g} fps)")


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


def add_camera(bpy, objects, camera, frames=None, options: Framing = Framing(), source=None) -> None:
    """Key `camera` (a view or a CameraTrack) on the scene, framing `objects` (splat
    objects; a track is tied to the first one's frame). frames: (start, end) or None.
    source: the first object's file, for messages."""
    from ..blender.data import capture_camera

    scene = bpy.context.scene
    if isinstance(camera, str):  # an orbit turns once over the range it is given, or the scene's
        if options.fps is not None:
            capture_camera.set_frame_rate(scene, options.fps)
        start, end = frames or (scene.frame_start, scene.frame_end)
        capture_camera.add_framing_camera(bpy.context, objects, camera, start, end, options.fill,
                                          options.elevation, options.lens, options.fov, options.azimuth)
        if camera == "capture":
            _say_capture_fallback(objects[0], source)
        return
    check_camera_options(camera, options)
    capture_camera.set_frame_rate(scene, camera.frame_rate)
    if frames is None:  # the scene plays the whole track
        scene.frame_end = scene.frame_start + camera.last_frame
    capture_camera.add_track_camera(bpy.context, camera, objects[0] if objects else None,
                                    scene.frame_start)


def _say_capture_fallback(obj, source) -> None:
    from ..blender.data.files import object_axes

    print(f"--camera capture: {source or obj.name} holds no camera (no format Splatline reads stores one): "
          f"looking along its forward axis ({object_axes(obj)} frame), from as far as the other views", flush=True)


def import_capture(bpy, path, **options):
    """A static capture as import_file imports it, a dynamic (4D) one as one object that
    plays by itself (only the axes option applies to it)."""
    from ..blender.data.dynamic_files import import_dynamic
    from ..blender.data.files import import_file
    from ..core.dynamic import is_dynamic_file
    from ..core.errors import SplatFormatError

    try:
        if is_dynamic_file(path):
            return import_dynamic(bpy.context, path, axes=options.get("axes", "AUTO"))
        return import_file(bpy.context, path, **options)
    except OSError as exc:
        raise SplatFormatError(path, exc.strerror or str(exc)) from None


def own_frames(obj) -> tuple[int, int] | None:
    """The frames a dynamic capture's own time range spans on the timeline, or None."""
    dynamic = obj.splatline.dynamic
    if not dynamic.enabled:
        return None
    span = (dynamic.time_end - dynamic.time_start) * dynamic.frames_per_unit
    start = int(round(dynamic.start_frame))
    return start, start + max(int(round(span)), 0)


def build(bpy, path, camera, frames=None, options: Framing = Framing(), axes="AUTO"):
    """Import `path` into the (empty) scene (its axis convention `axes`, AUTO: the file's),
    add the camera; returns the scene. A dynamic capture with no --frames or --seconds
    plays its own time range."""
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = frame_range(camera, frames)
    obj = import_capture(bpy, path, axes=axes)
    if frames is None and own_frames(obj) is not None:
        frames = own_frames(obj)
        scene.frame_start, scene.frame_end = frames
    scene.render.film_transparent = True  # a bare capture: alpha is the subject's coverage
    use_capture_colours(scene)
    try:
        add_camera(bpy, [obj], camera, frames, options, path)
    except ValueError as exc:
        raise UserError(f"{path}: cannot frame the capture: {exc}") from None
    return scene
