"""The equirectangular panoramic projection (Blender's PANO camera, EQUIRECTANGULAR).

Blender/Cycles (kernel direction_to_equirectangular_range, with the camera matrix
Cycles gives panoramas) maps a direction in Blender camera space (looks down -z, +y up)
to longitude lambda = atan2(x, -z) (0 straight ahead, positive to the right) and
latitude phi = atan2(y, hypot(x, z)), then linearly to the frame:
    u = W (lambda - lon_min) / (lon_max - lon_min),  v = H (lat_max - phi) / (lat_max - lat_min)
(top-left origin, y down). A core Camera holds this as fx = W / (lon_max - lon_min)
pixels per radian, fy likewise for latitude, cx = -lon_min fx, cy = lat_max fy, so
    u = cx + fx lambda,  v = cy - fy phi,
the perspective formula with (lambda, phi) in place of (x/-z, y/-z).

Splats are drawn as the EWA does for perspective: an affine approximation, J = the
Jacobian of (u, v) at the centre. Two things only a panorama has:
- Poles. d lambda / d(x, z) grows as 1 / cos(phi): a splat's footprint really does spread
  over every longitude near a pole, and at the pole J is singular. J is evaluated at the
  centre's longitude with its latitude clamped to +-(90 deg - half a pixel row), the
  latitude of the first and last row centres (as INRIA clamps x/z for J, never for the
  centre): finite, continuous through the pole, at most 1 / sin(half a row) times
  wider than at the equator.
- The seam. Longitude wraps every 2 pi, i.e. every `period` = 2 pi fx pixels. A splat
  whose quad reaches past either side of the frame is also drawn shifted by one period
  (seam_shifts), so one crossing the +-180 deg seam shows on both edges. Quads wider
  than a period (only a large splat within a few rows of a pole) are drawn at these
  three positions only.
Depth (the sort key, the near/far test and the depth pass) is the distance to the
camera: a panorama has no view axis.
"""
from __future__ import annotations

import math

import numpy as np

FULL_TURN = 2.0 * math.pi


def pole_margin(fy: float) -> float:
    """Half a pixel row of latitude (radians): how near a pole J is evaluated."""
    return 0.5 / float(fy)


def frame_params(width: int, height: int, lon_min: float, lon_max: float,
                 lat_min: float, lat_max: float) -> tuple[float, float, float, float]:
    """(fx, fy, cx, cy) of the frame's longitude/latitude window (radians)."""
    if not (lon_max > lon_min and lat_max > lat_min):
        raise ValueError(f"equirectangular range is empty: longitude {lon_min}..{lon_max}, "
                         f"latitude {lat_min}..{lat_max}")
    fx = width / (lon_max - lon_min)
    fy = height / (lat_max - lat_min)
    return fx, fy, -lon_min * fx, lat_max * fy


def angles(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) Blender camera-space points -> longitude, latitude (radians)."""
    x, y, z = t[:, 0], t[:, 1], t[:, 2]
    return np.arctan2(x, -z), np.arctan2(y, np.hypot(x, z))


def project_points(t: np.ndarray, camera) -> np.ndarray:
    """(N, 3) Blender camera-space points -> (N, 2) pixel u, v."""
    lam, phi = angles(t)
    return np.stack([camera.cx + camera.fx * lam, camera.cy - camera.fy * phi], axis=1)


def jacobian(t: np.ndarray, camera) -> np.ndarray:
    """(N, 2, 3) d(u, v)/d(x, y, z) in Blender camera axes at the centres t, with the
    latitude clamped near the poles (module docstring)."""
    lam, phi = angles(t)
    r = np.linalg.norm(t, axis=1)
    limit = 0.5 * math.pi - pole_margin(camera.fy)
    phi = np.clip(phi, -limit, limit)
    cl, sl, cp, sp = np.cos(lam), np.sin(lam), np.cos(phi), np.sin(phi)
    j = np.empty((t.shape[0], 2, 3))
    j[:, 0, 0] = camera.fx * cl / (r * cp)
    j[:, 0, 1] = 0.0
    j[:, 0, 2] = camera.fx * sl / (r * cp)
    j[:, 1, 0] = camera.fy * sp * sl / r
    j[:, 1, 1] = -camera.fy * cp / r
    j[:, 1, 2] = -camera.fy * sp * cl / r
    return j


def period(camera) -> float:
    """Pixels per full turn of longitude: where the image repeats."""
    return FULL_TURN * camera.fx


def seam_shifts(u: np.ndarray, radius: np.ndarray, camera) -> list[tuple[np.ndarray, float]]:
    """[(indices, shift in u)]: the splats also drawn one period to the right (their
    quad reaches past the left edge) and one to the left (past the right edge)."""
    p = period(camera)
    with np.errstate(invalid="ignore"):
        right = np.nonzero(u + p - radius < camera.width)[0]
        left = np.nonzero(u - p + radius > 0.0)[0]
    return [(right, p), (left, -p)]
