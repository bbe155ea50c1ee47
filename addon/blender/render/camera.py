"""Blender camera object + scene render settings -> core Camera."""
from __future__ import annotations

import numpy as np

from ...core.camera import Camera, camera_from_params, rigid_inverse

# What Blender renders through an object that is not a camera (BKE_camera_params_init).
_DEFAULT_LENS = 50.0
_DEFAULT_SENSOR = 36.0


def camera_from_blender(scene, camera_obj, depsgraph=None, *, matrix_world=None,
                        shift_x=None) -> Camera:
    """The projection Blender renders `scene` with through `camera_obj`.

    With a depsgraph the evaluated object is used (animated lens, drivers,
    constraints, parents). Border/crop is left to the render engine: the
    Camera always describes the full frame. matrix_world and shift_x override
    the object's, for one eye of a stereo pair (RenderEngine.camera_model_matrix
    and camera_shift_x give them per view).
    """
    obj = camera_obj.evaluated_get(depsgraph) if depsgraph is not None else camera_obj
    render = scene.render
    common = dict(
        resolution_x=render.resolution_x, resolution_y=render.resolution_y,
        percentage=render.resolution_percentage,
        pixel_aspect_x=render.pixel_aspect_x, pixel_aspect_y=render.pixel_aspect_y,
    )
    w2c = rigid_inverse(np.array(obj.matrix_world if matrix_world is None else matrix_world,
                                 np.float64))
    if obj.type != "CAMERA":
        return camera_from_params(w2c, lens=_DEFAULT_LENS, sensor_width=_DEFAULT_SENSOR,
                                  sensor_height=_DEFAULT_SENSOR, **common)
    cam = obj.data
    if cam.type == "PANO":
        raise ValueError(f"camera {camera_obj.name!r}: panoramic cameras are not supported")
    return camera_from_params(
        w2c, ortho=cam.type == "ORTHO", lens=cam.lens, ortho_scale=cam.ortho_scale,
        sensor_width=cam.sensor_width, sensor_height=cam.sensor_height,
        sensor_fit=cam.sensor_fit, shift_x=cam.shift_x if shift_x is None else shift_x,
        shift_y=cam.shift_y,
        clip_start=cam.clip_start, clip_end=cam.clip_end, **common,
    )
