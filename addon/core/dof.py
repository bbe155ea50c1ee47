"""Depth of field: the thin lens as a per-splat widening of the 2D covariance.

The lens (Cycles' model, which Blender's camera settings drive): a disk of radius
R = lens_mm * 1e-3 / (2 f-stop) scene units at the camera, every ray aimed at the point
it would hit on the plane in focus at distance F along the view axis. Seen from the lens
point a (camera x, y), a point at depth d lands shifted by -f a (1/d - 1/F) pixels
(f = fx or fy), the pinhole image otherwise (lens_camera gives that camera exactly).
Over the disk the shift is uniform on a disk of radius
    coc = f R |1/d - 1/F|  pixels (the circle of confusion),
whose variance per axis is coc^2 / 4. A splat's average over the aperture is its
Gaussian convolved with that disk; the renderers use the Gaussian of the same
variance: Sigma' + diag(fx^2, fy^2) (R (1/d - 1/F))^2 / 4 (d: the centre's depth),
with opacity scaled to keep the splat's integral (its energy), as gsplat's low-pass
compensation does. A splat at the focus distance is untouched. What this leaves out
(measured in bench/final_frame_bench.py): the disk is not a Gaussian, the shift varies
with depth across one splat, and compositing the average is not averaging composites
(occlusion seen from different lens points).
Deterministic: no sampling. Perspective cameras only (Blender's orthographic and
panoramic DOF are left out: the camera reader drops DOF there).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

@dataclass(frozen=True)
class Defocus:
    aperture_radius: float  # lens radius R in scene units
    focus_distance: float   # F: depth (along the view axis) of the plane in focus


def from_fstop(lens_mm: float, fstop: float, focus_distance: float) -> Defocus:
    """Blender's settings -> the lens (Cycles: aperturesize = lens * 1e-3 / (2 fstop))."""
    if not (fstop > 0 and focus_distance > 0 and lens_mm > 0):
        raise ValueError(f"depth of field needs f-stop, focus distance and lens > 0 "
                         f"(got {fstop}, {focus_distance}, {lens_mm})")
    return Defocus(lens_mm * 1e-3 / (2.0 * fstop), float(focus_distance))


def coc_radius(depth: np.ndarray, defocus: Defocus, focal: float) -> np.ndarray:
    """Circle-of-confusion radius in pixels at view depth `depth` (focal in px)."""
    return focal * defocus.aperture_radius * np.abs(1.0 / depth - 1.0 / defocus.focus_distance)


def widen(a0, c0, det0, depth, camera, antialiased: bool, low_pass: float):
    """The 2D covariance (before the low-pass of `low_pass` px^2) widened by the CoC
    variance.

    Returns a, c, det (b is unchanged) and the opacity factor that keeps each splat's
    integral: the low-passed footprint's sqrt(det) before over after; in antialiased
    mode sqrt(det0 / det), which with project's own compensation gives
    sqrt(det0 / det_lowpass), the antialiased splat's integral. Twin of sl_defocus."""
    k = camera.defocus.aperture_radius * (1.0 / depth - 1.0 / camera.defocus.focus_distance)
    vx = 0.25 * (camera.fx * k) ** 2
    vy = 0.25 * (camera.fy * k) ** 2
    a, c = a0 + vx, c0 + vy
    det = det0 + vx * c0 + vy * a0 + vx * vy  # det(S + diag(vx, vy)): non-negative terms
    if antialiased:
        factor = np.sqrt(det0 / det)
    else:
        before = det0 + low_pass * (a0 + c0) + low_pass * low_pass
        after = det + low_pass * (a + c) + low_pass * low_pass
        factor = np.sqrt(before / after)
    blurred = (vx > 0) | (vy > 0)  # in focus: exactly as without DOF (det0 may be 0)
    return a, c, np.where(blurred, det, det0), np.where(blurred, factor, 1.0)


def lens_samples(n: int) -> np.ndarray:
    """(n, 2) points spread evenly over the unit disk (Vogel's golden-angle spiral, each
    at the centre of its 1/n of the area): deterministic, no seed."""
    i = np.arange(n, dtype=np.float64)
    r = np.sqrt((i + 0.5) / n)
    theta = i * math.pi * (3.0 - math.sqrt(5.0))
    return np.stack([r * np.cos(theta), r * np.sin(theta)], axis=1)


def lens_camera(camera, point) -> object:
    """The pinhole camera seen from lens point `point` (unit-disk coordinates): moved by
    R point in its own x, y and its principal point shifted so that the plane in focus
    maps as before (an off-axis frustum). Same type as `camera`, DOF removed."""
    ax, ay = (float(v) * camera.defocus.aperture_radius for v in point)
    move = np.eye(4)
    move[0, 3], move[1, 3] = -ax, -ay
    f = camera.defocus.focus_distance
    return dataclasses.replace(camera, world_to_camera=move @ camera.world_to_camera,
                               cx=camera.cx + camera.fx * ax / f,
                               cy=camera.cy - camera.fy * ay / f, defocus=None)
