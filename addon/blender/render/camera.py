"""Blender camera object + scene render settings -> core Camera.

Besides the projection: depth of field from the camera's own DOF settings (use_dof, focus
object or distance, f-stop; blades and ratio are not modelled: the aperture is a round
disk), and the panoramic equirectangular camera (type PANO with panorama_type
EQUIRECTANGULAR and its latitude/longitude window). Where those properties live is found
by feature detection: Camera data holds them on 4.5..5.2; older Cycles kept them on
`camera.data.cycles`, which is read where the data itself has none.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core import dof
from ...core.camera import Camera, camera_from_params, equirect_camera, render_size, rigid_inverse

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
    world = np.array(obj.matrix_world if matrix_world is None else matrix_world, np.float64)
    w2c = rigid_inverse(world)
    if obj.type != "CAMERA":
        return camera_from_params(w2c, lens=_DEFAULT_LENS, sensor_width=_DEFAULT_SENSOR,
                                  sensor_height=_DEFAULT_SENSOR, **common)
    cam = obj.data
    if cam.type == "PANO":
        return _panorama(camera_obj.name, cam, w2c, render)
    camera = camera_from_params(
        w2c, ortho=cam.type == "ORTHO", lens=cam.lens, ortho_scale=cam.ortho_scale,
        sensor_width=cam.sensor_width, sensor_height=cam.sensor_height,
        sensor_fit=cam.sensor_fit, shift_x=cam.shift_x if shift_x is None else shift_x,
        shift_y=cam.shift_y,
        clip_start=cam.clip_start, clip_end=cam.clip_end, **common,
    )
    defocus = defocus_from_blender(cam, world, depsgraph)
    if defocus is None or camera.ortho:  # orthographic DOF is not modelled
        return camera
    return dataclasses.replace(camera, defocus=defocus)


def panorama_settings(cam):
    """The RNA owner of panorama_type and the latitude/longitude window: the camera
    data where it has them, else its Cycles settings; None where neither does."""
    for owner in (cam, getattr(cam, "cycles", None)):
        if owner is not None and "panorama_type" in owner.bl_rna.properties:
            return owner
    return None


def _panorama(name, cam, w2c, render) -> Camera:
    owner = panorama_settings(cam)
    kind = owner.panorama_type if owner is not None else "unknown"
    if kind != "EQUIRECTANGULAR":
        raise ValueError(f"camera {name!r}: panoramic type {kind} is not supported "
                         f"(Splatline renders EQUIRECTANGULAR panoramas)")
    width, height = render_size(render.resolution_x, render.resolution_y,
                                render.resolution_percentage)
    return equirect_camera(w2c, width, height, lon_min=owner.longitude_min,
                           lon_max=owner.longitude_max, lat_min=owner.latitude_min,
                           lat_max=owner.latitude_max, near=cam.clip_start, far=cam.clip_end)


def defocus_from_blender(cam, camera_world, depsgraph=None):
    """core Defocus from Camera.dof, or None where DOF is off."""
    settings = cam.dof
    if not settings.use_dof:
        return None
    distance = settings.focus_distance
    target = settings.focus_object
    if target is not None:
        target = target.evaluated_get(depsgraph) if depsgraph is not None else target
        distance = focus_object_distance(target, settings.focus_subtarget, camera_world)
    # Cycles clamps the f-stop at 1e-5; a focus distance of 0 would focus at the lens
    return dof.from_fstop(cam.lens, max(settings.aperture_fstop, 1e-5), max(distance, 1e-6))


def focus_object_distance(target, subtarget: str, camera_world) -> float:
    """Distance along the camera's view axis to the focus object (or its bone's head),
    as Cycles measures it."""
    m = np.array(target.matrix_world, np.float64)
    point = m[:3, 3]
    pose = getattr(target, "pose", None)
    if pose is not None and subtarget and subtarget in pose.bones:
        head = np.array(pose.bones[subtarget].head, np.float64)
        point = m[:3, :3] @ head + m[:3, 3]
    axis = camera_world[:3, 2] / np.linalg.norm(camera_world[:3, 2])
    return float(abs(np.dot(axis, camera_world[:3, 3] - point)))
