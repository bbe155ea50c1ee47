"""Per-object and per-camera values for the preprocess stage, computed in float64.

Everything is camera-relative: the camera position is taken into each object's own
frame in float64 and split into two float32s, so p - eye is exact on the GPU even for
a capture 1e6 from the origin with the camera beside it.
"""
from __future__ import annotations

import numpy as np

from ..core import equirect
from ..core.camera import Camera
from ..core.preprocess import camera_in_object, j_clamp_bounds, object_to_camera, split_float
from ..core.scene import RenderItem


def set_uniform(prog, name: str, value):
    """Set a uniform if the compiler kept it (unused ones are optimised away)."""
    try:
        member = prog[name]
    except KeyError:
        return
    if isinstance(value, np.ndarray):
        # GLSL matrices are column-major: write the transpose's rows
        member.write(np.ascontiguousarray(value.T, np.float32).tobytes())
    else:
        member.value = value


def camera_uniforms(camera: Camera) -> dict:
    w, h, fx, fy, cx, cy = camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy
    lo_x, hi_x, lo_y, hi_y = j_clamp_bounds(camera)  # of x/-z and y/-z (Blender camera axes)
    bounds = (lo_x, lo_y, hi_x, hi_y)
    return {
        "u_focal_centre": (fx, fy, cx, cy),
        "u_jac_bounds": tuple(float(b) for b in bounds),
        "u_frame": (float(w), float(h)),
        "u_near_far": (float(camera.near), float(camera.far)),
        "u_ortho": bool(camera.ortho),
        "u_equirect": bool(camera.equirect),
        "u_lat_limit": 0.5 * np.pi - equirect.pole_margin(fy) if camera.equirect else 0.0,
        "u_period": equirect.period(camera) if camera.equirect else 0.0,
        "u_lens": _lens(camera),
    }


def _lens(camera: Camera) -> tuple[float, float]:
    """Depth of field for sl_defocus: (aperture radius, 1 / focus distance); (0, 0) = off."""
    d = camera.defocus
    return (0.0, 0.0) if d is None else (float(d.aperture_radius), 1.0 / float(d.focus_distance))


def slots_per_splat(camera: Camera) -> int:
    """Record slots each splat owns in the frame arrays: 3 for an equirect camera (the
    splat and its seam copies one period to the right and left), else 1."""
    return 3 if camera.equirect else 1


def depth_origin(item: RenderItem, camera: Camera) -> float:
    """View depth of the item's origin (float64): the sort anchor of a frame."""
    return float(-(np.asarray(camera.world_to_camera, np.float64) @ np.asarray(item.world, np.float64))[2, 3])


def item_uniforms(item: RenderItem, camera: Camera, anchor: float = 0.0) -> dict:
    """anchor: a depth subtracted (in float64) from every sort depth of the frame."""
    o2c = object_to_camera(item, camera)
    cam_from_local = o2c[:3, :3]
    eye, fwd = camera_in_object(o2c)
    hi, lo = (tuple(float(v) for v in part) for part in split_float(eye))
    cm = np.asarray(item.color_matrix, np.float64)
    return {
        "u_cam_from_local": cam_from_local,
        "u_eye_hi": hi,
        "u_eye_lo": lo,
        "u_ortho_dir": tuple(float(v) for v in fwd),
        "u_depth_axis": tuple(float(v) for v in -o2c[2, :3]),
        "u_sort_offset": float(-o2c[2, 3] - anchor),
        "u_splat_scale": float(item.splat_scale),
        "u_opacity_scale": float(item.opacity_scale),
        "u_sh_degree": int(item.effective_sh_degree),
        "u_color_linear": cm[:, :3],
        "u_color_offset": tuple(float(v) for v in cm[:, 3]),
    }
