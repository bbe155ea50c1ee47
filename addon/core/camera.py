"""A pinhole or orthographic camera in pixel terms, shared by every renderer.

Conventions (Blender's): camera space looks down -z with +y up.
Image space: origin at the top-left corner, x right, y down, in pixels;
pixel (i, j) has its centre at (i + 0.5, j + 0.5). Images are stored
top-down, shape (height, width, channels).

Perspective:  u = cx + fx * x / -z,   v = cy - fy * y / -z
Orthographic: u = cx + fx * x,        v = cy - fy * y
Equirect:     u = cx + fx * lambda,   v = cy - fy * phi   (longitude, latitude; equirect.py)
A perspective camera may carry depth of field (`defocus`, dof.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import equirect as _equirect
from .dof import Defocus
from .matrix_inverse import inverse4


@dataclass(frozen=True)
class Camera:
    world_to_camera: np.ndarray  # (4, 4) float64, rigid: inverse of the camera's world matrix
    width: int
    height: int
    fx: float  # pixels per unit of x/-z (perspective) or per world unit (ortho)
    fy: float
    cx: float
    cy: float
    near: float
    far: float
    ortho: bool = False
    equirect: bool = False           # Blender's panoramic equirectangular camera
    defocus: Defocus | None = None   # depth of field (perspective only)

    def __post_init__(self):
        if self.defocus is not None and (self.ortho or self.equirect):
            raise ValueError("depth of field is modelled for perspective cameras only")
        if self.ortho and self.equirect:
            raise ValueError("a camera is orthographic or equirectangular, not both")

    @property
    def kind(self) -> str:
        """"perspective", "ortho" or "equirect"."""
        return "equirect" if self.equirect else "ortho" if self.ortho else "perspective"

    @property
    def camera_to_world(self) -> np.ndarray:
        return inverse4(self.world_to_camera)

    @property
    def position(self) -> np.ndarray:
        """Camera centre in world space (float64)."""
        return self.camera_to_world[:3, 3].copy()

    def project(self, points_world: np.ndarray) -> np.ndarray:
        """(N, 3) world points -> (N, 3) pixel u, v and depth, float64: camera-space
        depth (-z), or for an equirect camera the distance."""
        p = np.asarray(points_world, np.float64)
        cam = p @ self.world_to_camera[:3, :3].T + self.world_to_camera[:3, 3]
        depth = -cam[:, 2]
        if self.equirect:
            uv = _equirect.project_points(cam, self)
            return np.column_stack([uv, np.linalg.norm(cam, axis=1)])
        if self.ortho:
            u = self.cx + self.fx * cam[:, 0]
            v = self.cy - self.fy * cam[:, 1]
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                u = self.cx + self.fx * cam[:, 0] / depth
                v = self.cy - self.fy * cam[:, 1] / depth
        return np.stack([u, v, depth], axis=1)


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """world_to_camera for a camera at eye looking at target (Blender convention)."""
    eye, target, up = (np.asarray(v, np.float64) for v in (eye, target, up))
    back = eye - target
    back /= np.linalg.norm(back)
    right = np.cross(up, back)
    if np.linalg.norm(right) < 1e-12:  # looking along up: pick any perpendicular
        right = np.cross((0.0, 1.0, 0.0), back)
    right /= np.linalg.norm(right)
    true_up = np.cross(back, right)
    cam_to_world = np.eye(4)
    cam_to_world[:3, 0], cam_to_world[:3, 1], cam_to_world[:3, 2] = right, true_up, back
    cam_to_world[:3, 3] = eye
    return inverse4(cam_to_world)


def simple_camera(width: int, height: int, fov_x_deg: float, world_to_camera,
                  near: float = 0.1, far: float = 1000.0) -> Camera:
    """A centred perspective camera with square pixels, for tests and benchmarks."""
    fx = width / (2.0 * np.tan(np.radians(fov_x_deg) / 2.0))
    return Camera(np.asarray(world_to_camera, np.float64), width, height, fx, fx,
                  width / 2.0, height / 2.0, near, far)


SENSOR_FITS = ("AUTO", "HORIZONTAL", "VERTICAL")


def render_size(resolution_x: int, resolution_y: int, percentage: int = 100) -> tuple[int, int]:
    """Pixel size of the rendered frame, rounded the way Blender does (integer division)."""
    return (int(resolution_x) * int(percentage)) // 100, (int(resolution_y) * int(percentage)) // 100


def camera_from_params(world_to_camera, *, resolution_x: int, resolution_y: int,
                       percentage: int = 100, ortho: bool = False, lens: float = 50.0,
                       ortho_scale: float = 6.0, sensor_width: float = 36.0,
                       sensor_height: float = 24.0, sensor_fit: str = "AUTO",
                       shift_x: float = 0.0, shift_y: float = 0.0,
                       clip_start: float = 0.1, clip_end: float = 1000.0,
                       pixel_aspect_x: float = 1.0, pixel_aspect_y: float = 1.0) -> Camera:
    """The exact projection Blender renders with (BKE_camera_params_compute_viewplane).

    Blender sizes the view plane from one "fit" dimension: the sensor (or the ortho
    scale) spans `viewfac` pixels, where viewfac is the frame width for a horizontal
    fit and the height times ycor (= pixel_aspect_y / pixel_aspect_x) for a vertical
    one. AUTO fits whichever side is larger in aspect-corrected pixels, and uses
    sensor_width for it either way. Shifts are in units of viewfac. A pixel is ycor
    units tall for 1 unit wide, so fy = fx / ycor.
    """
    if sensor_fit not in SENSOR_FITS:
        raise ValueError(f"sensor_fit {sensor_fit!r} is not one of {SENSOR_FITS}")
    width, height = render_size(resolution_x, resolution_y, percentage)
    if width < 1 or height < 1:
        raise ValueError(f"render size {width}x{height} is empty")
    ycor = float(pixel_aspect_y) / float(pixel_aspect_x)
    if sensor_fit == "AUTO":
        horizontal = pixel_aspect_x * width >= pixel_aspect_y * height
    else:
        horizontal = sensor_fit == "HORIZONTAL"
    viewfac = float(width) if horizontal else ycor * height
    if ortho:
        fx = viewfac / float(ortho_scale)
    else:
        sensor = sensor_height if sensor_fit == "VERTICAL" else sensor_width
        fx = float(lens) * viewfac / float(sensor)
    fy = fx / ycor
    cx = width / 2.0 - shift_x * viewfac
    cy = height / 2.0 + shift_y * viewfac / ycor
    return Camera(np.asarray(world_to_camera, np.float64), width, height, fx, fy, cx, cy,
                  float(clip_start), float(clip_end), bool(ortho))


def rigid_inverse(camera_to_world) -> np.ndarray:
    """world_to_camera from a camera's world matrix with its scale removed.

    Blender renders from the camera matrix with each axis normalised (normalize_m4),
    so a scaled camera object sees the same picture as an unscaled one.
    """
    m = np.array(camera_to_world, np.float64)
    m[:3, :3] /= np.linalg.norm(m[:3, :3], axis=0)
    return inverse4(m)


def equirect_camera(world_to_camera, width: int, height: int, *,
                    lon_min: float = -np.pi, lon_max: float = np.pi,
                    lat_min: float = -np.pi / 2, lat_max: float = np.pi / 2,
                    near: float = 0.1, far: float = 1000.0) -> Camera:
    """A panoramic equirectangular camera over the given longitude/latitude window
    (radians; Blender's defaults: the whole sphere)."""
    if width < 1 or height < 1:
        raise ValueError(f"render size {width}x{height} is empty")
    fx, fy, cx, cy = _equirect.frame_params(width, height, lon_min, lon_max, lat_min, lat_max)
    return Camera(np.asarray(world_to_camera, np.float64), int(width), int(height), fx, fy,
                  cx, cy, float(near), float(far), equirect=True)
