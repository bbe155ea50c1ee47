"""Per-splat preprocessing in float64, vectorised over splats: the reference's
projection, shared with test oracles. INRIA's forward pass (preprocessCUDA) with
Blender's camera; see docs/DESIGN.md "Rendering semantics".

Conventions and the choices the renderers must agree on:
- Everything is computed camera-relative: the object-to-camera matrix is
  composed in float64 first, so a capture 1e6 from the origin with the camera
  beside it loses nothing to the large translation.
- Screen space is INRIA's: x right, y down, z forward (Blender's camera looks
  down -z with +y up, so x' = x, y' = -y, z' = -z). u = cx + fx x'/z'.
- J's clamp: INRIA clamps x/z and y/z to +-1.3 tan(fov/2). Generalised to
  shifted cameras as the same margin around the actual frame: u and v of the
  point used in J are clamped to [-0.15 W, 1.15 W] and [-0.15 H, 1.15 H]
  pixels (j_clamp_bounds). For an unshifted camera this is exactly INRIA's.
- Culled (valid = False): centre depth <= near or > far, opacity < 1/255 (no
  pixel could reach the 1/255 cut), zero/NaN quaternion, det <= 0, and any
  non-finite value in the inputs or results.
- Extent (in sigmas): sqrt(2 ln(255 o)), the alpha = 1/255 contour (3.33 at
  o = 1; alpha = min(0.99, ...) does not move it, 0.99 > 1/255), so the quad
  holds the exact footprint. capped_extent (a speed setting of the fast
  paths) cuts it at 3 sigma: min(3, sqrt(2 ln(255 o))).
  `radius` = extent * sqrt(lambda_max) in pixels (not rounded) is the half-size
  of the screen-aligned square quad the splat covers.
- Zero quaternions are culled, like NaN ones (not treated as the identity).
- Equirect cameras (equirect.py): J and the centre from the longitude/latitude map,
  depth = distance to the camera; the seam copies are the renderer's (seam_shifts).
- Depth of field (dof.py): the 2D covariance, before the low-pass, gains the circle of
  confusion's variance, and opacity the factor that keeps the splat's integral.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import dof, equirect
from .camera import Camera
from .matrix_inverse import inverse_or_pinv, thickened
from .quaternion import to_matrix as quat_to_matrix
from .render_constants import ALPHA_MIN, J_CLAMP_MARGIN, LOW_PASS
from .scene import RenderItem
from .sh import sh_to_rgb

_FLIP = np.diag([1.0, -1.0, -1.0])  # Blender camera -> INRIA screen axes


@dataclass
class Projected:
    """Arrays over the item's splats (N). Rows with valid = False hold junk."""

    means2d: np.ndarray  # (N, 2) pixel centre u, v (top-left origin, y down)
    cov2d: np.ndarray    # (N, 3) a, b, c of the 2D covariance incl. low-pass, px^2
    conic: np.ndarray    # (N, 3) inverse of cov2d: A, B, C; power = -(A dx^2 + C dy^2)/2 - B dx dy
    opacity: np.ndarray  # (N,) opacity * opacity_scale (* antialias compensation)
    rgb: np.ndarray      # (N, 3) colour after the colour matrix, clamped at 0
    depth: np.ndarray    # (N,) view-space depth of the centre (-z)
    extent: np.ndarray   # (N,) quad half-extent in sigmas of the major axis
    radius: np.ndarray   # (N,) quad half-size in pixels: extent * sqrt(lambda_max)
    valid: np.ndarray    # (N,) bool

    @property
    def count(self) -> int:
        return int(self.valid.shape[0])


def object_to_camera(item: RenderItem, camera: Camera) -> np.ndarray:
    """(4, 4) float64 matrix from the item's local frame to Blender camera space (a
    flattened object's thickened: matrix_inverse.thickened)."""
    return np.asarray(camera.world_to_camera, np.float64) @ thickened(item.world)


def local_view_dirs(item: RenderItem, camera: Camera, pos_local: np.ndarray) -> np.ndarray:
    """Unit view directions (camera -> centre) in the item's local frame.

    Perspective: normalize(centre - camera position), both local. Orthographic:
    the camera's forward axis taken into the local frame. With a non-rigid
    object matrix, local directions are A^-1 times world directions.
    """
    eye, forward = camera_in_object(object_to_camera(item, camera))
    with np.errstate(all="ignore"):
        d = np.broadcast_to(forward, pos_local.shape) if camera.ortho else pos_local - eye
        return d / np.linalg.norm(d, axis=1, keepdims=True)


def j_clamp_bounds(camera: Camera) -> tuple[float, float, float, float]:
    """(lo_x, hi_x, lo_y, hi_y): where x/depth and y/depth (Blender camera axes,
    y up) are clamped before building J. The frame plus a margin of 15 % of its
    size beyond each edge; for an unshifted camera this is INRIA's
    +-1.3 tan(fov/2), and it follows the frame when the lens is shifted."""
    mx, my = J_CLAMP_MARGIN * camera.width, J_CLAMP_MARGIN * camera.height
    lo_x = (-mx - camera.cx) / camera.fx
    hi_x = (camera.width + mx - camera.cx) / camera.fx
    lo_y = (camera.cy - camera.height - my) / camera.fy  # v = cy - fy * y/depth
    hi_y = (camera.cy + my) / camera.fy
    return lo_x, hi_x, lo_y, hi_y


def _jacobian(t: np.ndarray, camera: Camera) -> np.ndarray:
    """(N, 2, 3) d(u, v)/d(x', y', z') at camera-space centres t (INRIA axes)."""
    n = t.shape[0]
    if camera.equirect:  # d(u, v)/d(Blender axes), chained through t_blender = FLIP t
        return equirect.jacobian(t * _FLIP.diagonal(), camera) * _FLIP.diagonal()
    j = np.zeros((n, 2, 3))
    if camera.ortho:
        j[:, 0, 0], j[:, 1, 1] = camera.fx, camera.fy
        return j
    z = t[:, 2]
    lo_x, hi_x, lo_y, hi_y = j_clamp_bounds(camera)
    tx = np.clip(t[:, 0] / z, lo_x, hi_x)
    ty = -np.clip(-t[:, 1] / z, lo_y, hi_y)  # t is y-down; the bounds are y-up
    j[:, 0, 0] = camera.fx / z
    j[:, 0, 2] = -camera.fx * tx / z
    j[:, 1, 1] = camera.fy / z
    j[:, 1, 2] = -camera.fy * ty / z
    return j


def _covariance_2d(g: np.ndarray, s: np.ndarray):
    """2D covariance of M = G diag(s) (M M^T), with its determinant computed
    from 2x2 minors (Cauchy-Binet): sum_{i<j} (s_i s_j g_ij)^2 never cancels,
    so needles and discs with anisotropy 1e8 keep an accurate, positive det."""
    m = g * s[:, None, :]
    a = np.einsum("nk,nk->n", m[:, 0], m[:, 0])
    b = np.einsum("nk,nk->n", m[:, 0], m[:, 1])
    c = np.einsum("nk,nk->n", m[:, 1], m[:, 1])
    det = np.zeros_like(a)
    for i, j in ((0, 1), (0, 2), (1, 2)):
        minor = g[:, 0, i] * g[:, 1, j] - g[:, 0, j] * g[:, 1, i]
        det += (minor * s[:, i] * s[:, j]) ** 2
    return a, b, c, det


CAP_SIGMAS = 3.0  # the capped extent: INRIA's tile bound, a speed setting here


def extent_sigmas(opacity: np.ndarray, capped: bool = False) -> np.ndarray:
    """Half-extent in sigmas: where alpha falls to 1/255 (the exact footprint), or,
    capped, no farther than 3 sigma (drops the ring of alpha < 0.011 beyond)."""
    with np.errstate(all="ignore"):
        cut = np.sqrt(np.maximum(2.0 * np.log(255.0 * opacity), 0.0))
    return np.minimum(CAP_SIGMAS, cut) if capped else cut


def project(item: RenderItem, camera: Camera, antialiased: bool = False,
            capped_extent: bool = False) -> Projected:
    """Project one item's splats for `camera` (float64, per DESIGN.md)."""
    sp = item.splats
    with np.errstate(all="ignore"):
        o2c = object_to_camera(item, camera)
        lin = _FLIP @ o2c[:3, :3]
        pos = sp.positions.astype(np.float64)
        t = pos @ lin.T + _FLIP @ o2c[:3, 3]
        depth = np.linalg.norm(t, axis=1) if camera.equirect else t[:, 2]
        rot, q_ok = quat_to_matrix(sp.rotations)
        g = np.matmul(_jacobian(t, camera) @ lin, rot)
        s = sp.scales.astype(np.float64) * float(item.splat_scale)
        a0, b, c0, det0 = _covariance_2d(g, s)
        opacity = sp.opacities.astype(np.float64) * float(item.opacity_scale)
        if camera.defocus is not None:
            a0, c0, det0, keep = dof.widen(a0, c0, det0, depth, camera, antialiased, LOW_PASS)
            opacity = opacity * keep
        a, c = a0 + LOW_PASS, c0 + LOW_PASS
        det = det0 + LOW_PASS * (a0 + c0) + LOW_PASS * LOW_PASS
        conic = np.stack([c, -b, a], axis=1) / det[:, None]
        if antialiased:
            opacity = opacity * np.sqrt(np.maximum(det0 / det, 0.0))
        extent = extent_sigmas(opacity, capped_extent)
        # lambda_max = mid + sqrt(max(0.1, mid^2 - det)); mid^2 - det written without cancellation
        lam = 0.5 * (a + c) + np.sqrt(np.maximum(0.1, 0.25 * (a - c) ** 2 + b * b))
        radius = extent * np.sqrt(lam)
        means = _centres(t, depth, camera)
        rgb = _colours(item, camera, pos)
    valid = (q_ok & (depth > camera.near) & (depth <= camera.far) & (det > 0)
             & (opacity >= ALPHA_MIN) & np.isfinite(radius) & np.isfinite(det)
             & np.isfinite(means).all(1) & np.isfinite(conic).all(1)
             & np.isfinite(rgb).all(1) & np.isfinite(opacity))
    return Projected(means, np.stack([a, b, c], 1), conic, opacity, rgb, depth, extent,
                     radius, valid)


def _centres(t: np.ndarray, depth: np.ndarray, camera: Camera) -> np.ndarray:
    """(N, 2) pixel centres of camera-space points t (INRIA axes)."""
    if camera.equirect:
        return equirect.project_points(t * _FLIP.diagonal(), camera)
    if camera.ortho:
        return np.stack([camera.cx + camera.fx * t[:, 0], camera.cy + camera.fy * t[:, 1]], 1)
    return np.stack([camera.cx + camera.fx * t[:, 0] / depth,
                     camera.cy + camera.fy * t[:, 1] / depth], 1)


def _colours(item: RenderItem, camera: Camera, pos_local: np.ndarray) -> np.ndarray:
    """SH colour in the local frame, then the colour matrix, clamped at 0."""
    degree = item.effective_sh_degree
    sp = item.splats
    dirs = local_view_dirs(item, camera, pos_local) if degree > 0 else np.zeros_like(pos_local)
    rgb = sh_to_rgb(sp.sh_dc.astype(np.float64), sp.sh_rest.astype(np.float64), dirs, degree)
    cm = np.asarray(item.color_matrix, np.float64)
    rgb = rgb @ cm[:, :3].T + cm[:, 3]
    return np.maximum(rgb, 0.0)


def camera_in_object(local_to_camera: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(eye, forward): the camera centre and its unit viewing direction (-z) in an object's
    local frame, from the object-to-camera matrix (float64). pinv: an object shrunk to a
    point gives junk the renderers cull (object_to_camera thickens a plane or a line). `forward` is what orthographic views use as every
    splat's SH direction."""
    m = np.asarray(local_to_camera, np.float64)
    with np.errstate(all="ignore"):
        inv = inverse_or_pinv(m[:3, :3])  # no LAPACK: once per object per frame
        eye = -inv @ m[:3, 3]
        forward = inv @ np.array([0.0, 0.0, -1.0])
        forward = forward / np.linalg.norm(forward)
    return eye, forward


def split_float(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """float64 values as float32 (hi, lo) with hi + lo close to x in float64: how the
    shaders take the camera centre without losing precision far from the origin."""
    x = np.asarray(x, np.float64)
    hi = x.astype(np.float32)
    return hi, (x - hi.astype(np.float64)).astype(np.float32)
