"""Default cameras for a bare capture: robust bounds, a front view and an orbit.

A capture's own frame decides what "up" and "front" mean: its up is the file's up axis
(-y for the RDF frame of 3DGS/COLMAP files, +y for RUB, +z for RFU) and its forward is the
direction its reference camera looked (+z in RDF, -z in RUB, +y in RFU). The front view
stands behind that camera's position and looks along forward, with the capture's up. For an
RDF capture imported with Splatline's axis rotation that is Blender's Front view (-Y,
looking +Y, z up). The orbit starts at the front view, lifted by ELEVATION_DEG, and turns
once about the capture's up axis over the frame range, counter-clockwise seen from above.

Bounds come from the 2nd and 98th percentiles of the world-space centres, so a few
floaters far from the subject neither shrink it (by pushing the camera away) nor move the
point looked at. The camera is distant enough that the sphere around those bounds (with a
margin for the tips the percentiles trim) fits the narrower side of the frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .axes import matrix_for
from .camera import look_at

LOW_PERCENTILE, HIGH_PERCENTILE = 2.0, 98.0
MARGIN = 1.15  # the percentile box trims the subject's tips (a guitar's headstock): give them room
ELEVATION_DEG = 20.0  # above the horizon: a look slightly down reads as "in front of it"
MODES = ("orbit", "front")


@dataclass(frozen=True)
class Bounds:
    centre: np.ndarray  # (3,) world
    low: np.ndarray
    high: np.ndarray

    @property
    def radius(self) -> float:
        """Half the diagonal of the percentile box; never zero (a one-point capture)."""
        return max(0.5 * float(np.linalg.norm(self.high - self.low)), 1e-3)

    @property
    def size(self) -> float:
        """The percentile box's diagonal (0 for a one-point capture)."""
        return float(np.linalg.norm(self.high - self.low))


def robust_bounds(points_world, low=LOW_PERCENTILE, high=HIGH_PERCENTILE) -> Bounds:
    """Per-axis percentile box of the finite points, and its middle."""
    pts = np.asarray(points_world, np.float64).reshape(-1, 3)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if len(pts) == 0:
        raise ValueError("no finite splat centres to frame")
    lo, hi = np.percentile(pts, [low, high], axis=0)
    return Bounds((lo + hi) / 2.0, lo, hi)


def capture_axes(axes: str, object_rotation) -> tuple[np.ndarray, np.ndarray]:
    """The capture's (up, forward) in world space, for an object whose matrix takes its
    file frame (convention `axes`) to the world. Blender's (z, y) pulled back into the file
    frame through the axis rotation, then pushed out through the object's own rotation."""
    to_blender = matrix_for(axes)
    file_up, file_forward = to_blender.T @ (0.0, 0.0, 1.0), to_blender.T @ (0.0, 1.0, 0.0)
    rotation = np.asarray(object_rotation, np.float64)[:3, :3]
    up, forward = rotation @ file_up, rotation @ file_forward
    return up / np.linalg.norm(up), forward / np.linalg.norm(forward)


def fit_distance(bounds: Bounds, tan_half_x: float, tan_half_y: float) -> float:
    """Centre-to-camera distance at which the bounds' sphere, MARGIN times larger, fits the
    narrower field (a sphere: the orbit sees the subject from every side)."""
    half = math.atan(min(tan_half_x, tan_half_y))
    return MARGIN * bounds.radius / math.sin(half)


def fit_box_distance(bounds: Bounds, tan_half_x: float, tan_half_y: float) -> float:
    """Distance from the centre at which the box's horizontal diagonal fits the width and
    its height (world z) fits the height of the frame, plus half that diagonal (the near
    side): a tighter fit than fit_distance's sphere, for a view that stays near the side."""
    extent = bounds.high - bounds.low
    width, height = float(np.linalg.norm(extent[:2])), float(extent[2])
    return max(width / 2 / tan_half_x, height / 2 / tan_half_y) + width / 2


def front_pose(bounds: Bounds, up, forward, distance: float) -> np.ndarray:
    """Camera-to-world matrix of the front view."""
    return _pose_at(bounds, up, forward, distance, 0.0, 0.0)


def orbit_poses(bounds: Bounds, up, forward, distance: float, count: int) -> list:
    """`count` camera-to-world matrices, one a frame, evenly round a full turn (the turn's
    end is the next loop's start, so a looped render does not repeat a frame)."""
    return [_pose_at(bounds, up, forward, distance, 2.0 * math.pi * i / count,
                     math.radians(ELEVATION_DEG)) for i in range(count)]


def _pose_at(bounds, up, forward, distance, azimuth, elevation) -> np.ndarray:
    up, forward = np.asarray(up, np.float64), np.asarray(forward, np.float64)
    forward = forward - up * float(forward @ up)  # level the view: forward in the horizon plane
    forward /= np.linalg.norm(forward)
    side = np.cross(up, forward)  # a quarter turn counter-clockwise about up
    back = -(forward * math.cos(azimuth) + side * math.sin(azimuth))
    direction = back * math.cos(elevation) + up * math.sin(elevation)
    eye = bounds.centre + distance * direction
    return np.linalg.inv(look_at(eye, bounds.centre, up))


def clip_range(bounds: Bounds, distance: float) -> tuple[float, float]:
    """Near and far planes that keep the whole percentile sphere and far floaters."""
    return max(1e-4, 0.01 * bounds.radius), 10.0 * (distance + bounds.radius)
