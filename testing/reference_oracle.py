"""An independent oracle for the reference renderer, written the plain way from
DESIGN.md (not from preprocess.py): per splat, Sigma' = J W R S S R^T W^T J^T and
det = ac - b^2 in exact rational arithmetic (fractions) from the float64
inputs; pixels in long double; back-to-front "over" compositing. Slow: for a
few thousand splats on small frames.
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np

LD = np.longdouble

# INRIA diff-gaussian-rasterization forward.cu, written out here and not imported from
# addon.core.sh, so the oracle checks the renderer's SH instead of sharing its code
# (tests/core/test_sh_oracle.py checks these against the closed forms sqrt((2l+1)/4pi ...)).
SH_C0 = 0.28209479177387814
SH_C1 = 0.4886025119029199
SH_C2 = (1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792,
         0.5462742152960396)
SH_C3 = (-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154,
         -0.4570457994644658, 1.445305721320277, -0.5900435899266435)


def sh_rgb(dc, rest, d, degree):
    """INRIA's computeColorFromSH for one splat: dc (3,), rest (K, 3), unit direction d,
    before the clamp at 0. Term by term as in forward.cu, in long double."""
    sh = [np.asarray(dc, LD)] + [np.asarray(r, LD) for r in rest]
    x, y, z = (LD(v) for v in d)
    result = SH_C0 * sh[0]
    if degree > 0:
        result = result - SH_C1 * y * sh[1] + SH_C1 * z * sh[2] - SH_C1 * x * sh[3]
    if degree > 1:
        xx, yy, zz, xy, yz, xz = x * x, y * y, z * z, x * y, y * z, x * z
        result = (result + SH_C2[0] * xy * sh[4] + SH_C2[1] * yz * sh[5]
                  + SH_C2[2] * (2.0 * zz - xx - yy) * sh[6] + SH_C2[3] * xz * sh[7]
                  + SH_C2[4] * (xx - yy) * sh[8])
        if degree > 2:
            result = (result + SH_C3[0] * y * (3.0 * xx - yy) * sh[9] + SH_C3[1] * xy * z * sh[10]
                      + SH_C3[2] * y * (4.0 * zz - xx - yy) * sh[11]
                      + SH_C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy) * sh[12]
                      + SH_C3[4] * x * (4.0 * zz - xx - yy) * sh[13]
                      + SH_C3[5] * z * (xx - yy) * sh[14] + SH_C3[6] * x * (xx - 3.0 * yy) * sh[15])
    return result + 0.5


def quat_matrix(q):
    w, x, y, z = np.asarray(q, LD) / np.sqrt(np.sum(np.asarray(q, LD) ** 2))
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]], LD)


def _exact(a):
    return np.vectorize(lambda x: Fraction(float(x)), otypes=[object])(np.asarray(a, np.float64))


def _camera_point(cam, world, pos):
    m = np.asarray(cam.world_to_camera, LD) @ np.asarray(world, LD)
    flip = np.diag(np.array([1, -1, -1], LD))  # Blender camera -> x right, y down, z forward
    lin = flip @ m[:3, :3]
    return lin, lin @ np.asarray(pos, LD) + flip @ m[:3, 3]


def _jacobian(cam, t):
    fx, fy = LD(cam.fx), LD(cam.fy)
    if cam.ortho:
        return np.array([[fx, 0, 0], [0, fy, 0]], LD), cam.cx + fx * t[0], cam.cy + fy * t[1]
    z = t[2]
    u, v = cam.cx + fx * t[0] / z, cam.cy + fy * t[1] / z
    # INRIA's clamp of x/z, y/z (J only), as a 15 % margin beyond each frame edge.
    tx = np.clip(t[0] / z, (-0.15 * cam.width - cam.cx) / fx, (1.15 * cam.width - cam.cx) / fx)
    ty = np.clip(t[1] / z, (-0.15 * cam.height - cam.cy) / fy, (1.15 * cam.height - cam.cy) / fy)
    return np.array([[fx / z, 0, -fx * tx / z], [0, fy / z, -fy * ty / z]], LD), u, v


def splat_alpha(cam, pos, scale, quat=(1, 0, 0, 0), opacity=0.9, world=None, capped=False):
    """(alpha image, depth), or (None, depth) for a culled splat."""
    world = np.eye(4) if world is None else world
    lin, t = _camera_point(cam, world, pos)
    if not (cam.near < t[2] <= cam.far) or opacity < 1 / 255:
        return None, t[2]
    jac, u, v = _jacobian(cam, t)
    mat = _exact(jac) @ _exact(lin) @ _exact(quat_matrix(quat)) @ np.diag(_exact(scale))
    cov = mat @ mat.T
    a, b, c = cov[0, 0] + Fraction(3, 10), cov[0, 1], cov[1, 1] + Fraction(3, 10)
    det = a * c - b * b
    mid = (a + c) / 2
    lam = LD(mid) + np.sqrt(max(LD(0.1), LD(mid * mid - det)))
    extent = np.sqrt(2 * np.log(255 * float(opacity)))  # alpha = 1/255: the exact footprint
    extent = min(3.0, extent) if capped else extent
    radius = extent * np.sqrt(lam)
    ys, xs = np.mgrid[0:cam.height, 0:cam.width].astype(LD) + LD(0.5)
    dx, dy = xs - u, ys - v
    m2 = LD(c / det) * dx * dx - 2 * LD(b / det) * dx * dy + LD(a / det) * dy * dy
    alpha = np.minimum(LD(0.99), LD(float(opacity)) * np.exp(-m2 / 2))
    inside = (np.abs(dx) <= radius) & (np.abs(dy) <= radius) & (alpha >= LD(1) / 255)
    return np.where(inside, alpha, 0), t[2]


def splat_rgb(cam, item, i):
    """Colour of splat i of item: SH with the view direction in the item's local frame."""
    sp, world = item.splats, np.asarray(item.world, np.float64)
    inv = np.linalg.inv(world)
    p = sp.positions[i].astype(np.float64)
    if cam.ortho:
        d = inv[:3, :3] @ -np.linalg.inv(cam.world_to_camera)[:3, 2]
    else:
        d = p - (inv[:3, :3] @ cam.position + inv[:3, 3])
    d = d / np.linalg.norm(d)
    deg = item.effective_sh_degree
    rgb = sh_rgb(sp.sh_dc[i].astype(np.float64), sp.sh_rest[i].astype(np.float64), d, deg).astype(np.float64)
    cm = np.asarray(item.color_matrix, np.float64)
    return np.maximum(cm[:, :3] @ rgb + cm[:, 3], 0.0)


def render_oracle(items, cam, capped=False):
    """Premultiplied RGBA (long double): back to front, C = alpha c + (1 - alpha) C;
    equal depths: the lower global index in front (drawn last)."""
    layers = []
    for item in items:
        sp = item.splats
        for i in range(sp.count):
            o = float(sp.opacities[i]) * item.opacity_scale
            alpha, depth = splat_alpha(cam, sp.positions[i], sp.scales[i] * item.splat_scale,
                                       sp.rotations[i], o, item.world, capped)
            if alpha is not None:
                layers.append((depth, len(layers), alpha, splat_rgb(cam, item, i)))
    out = np.zeros((cam.height, cam.width, 4), LD)
    for _, _, alpha, rgb in sorted(layers, key=lambda layer: (-layer[0], -layer[1])):
        out[..., :3] = alpha[..., None] * np.asarray(rgb, LD) + (1 - alpha[..., None]) * out[..., :3]
        out[..., 3] = alpha + (1 - alpha) * out[..., 3]
    return out
