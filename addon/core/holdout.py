"""Meshes hide splats: opaque surfaces as a per-pixel depth, and the rule that drops the
splat fragments behind them (issue 25). Pure numpy, float64.

The model. A 3DGS splat is ordered by its centre depth alone: for compositing it is a
flat sheet at that depth. A mesh holds out the splats the same way, per fragment:
a splat's contribution to pixel p (its fragment there) is composited only where
    z_i < holdout_depth[p],
z_i the depth of splat i's centre and holdout_depth[p] the depth of the nearest opaque
surface under p's centre. A plane through a capture therefore hides, at each pixel, only
the splats whose centres lie behind the plane along that pixel's ray: the same splat
can be hidden at one pixel and shown at its neighbour. (KIRI's Blender add-on does the
same with a depth pass.) Dropped fragments leave the pixel's transmittance alone, so
the splats in front and early termination behave as without the surface.

Depth, the measure the splats are sorted by (preprocess.py): camera-space depth (-z) for
perspective and orthographic cameras, the distance from the camera centre for
equirectangular ones. With depth of field the surface is seen through the pinhole
(lens centre) ray, as the splats' centres are.

holdout_depth casts each pixel-centre ray (pixel (i, j) at (i + 0.5, j + 0.5), top-left
origin, as camera.py) exactly in float64 (Moeller-Trumbore) against every triangle
whose screen bounding box holds that centre. Both faces count (no backface culling);
edges are inclusive. A hit counts where a splat centre there would be drawn:
near < depth <= far (clip start excluded, clip end included); elsewhere, and where no
triangle is hit, the depth is inf.

What is approximate (docs/rendering.md): transparent or alpha-blended meshes hide as if
opaque, splats appear in no reflection or refraction, and they cast no shadows on meshes
(meshes shadow lit splats: core/lighting/shadows.py).
"""
from __future__ import annotations

import hashlib

import numpy as np

from .camera import Camera

_SIZES = np.array([1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64])  # padded block sides
_BLOCK = 64          # rectangles larger than this are cut into 64 x 64 blocks
_CHUNK = 1 << 20     # pixels per vectorised step
_MARGIN = 1.0        # pixels around each bounding box (the exact test decides)


class Holdout:
    """Opaque surfaces that hide splats: `triangles` (T, 3, 3) float64 world-space vertices.

    Stored as a read-only C-contiguous float64 copy. `key` is a hash of the triangles'
    bytes (and shape), computed once: equal keys mean equal triangles, so renderers may
    cache their uploads by it. Equality and hash are by key, so a Holdout can sit in
    the frozen RenderOptions."""

    __slots__ = ("triangles", "key")

    def __init__(self, triangles):
        tri = np.array(triangles, dtype=np.float64, order="C", copy=True)
        if tri.ndim != 3 or tri.shape[1:] != (3, 3):
            raise ValueError(f"holdout triangles must have shape (T, 3, 3), got {tri.shape}")
        if not np.isfinite(tri).all():
            raise ValueError("holdout triangles hold non-finite coordinates")
        tri.flags.writeable = False
        self.triangles = tri
        digest = hashlib.blake2b(tri.tobytes(), digest_size=16)
        digest.update(repr(tri.shape).encode())
        self.key = digest.hexdigest()

    @property
    def count(self) -> int:
        return int(self.triangles.shape[0])

    def __eq__(self, other):
        return isinstance(other, Holdout) and other.key == self.key

    def __hash__(self):
        return hash(self.key)

    def __repr__(self):
        return f"Holdout({self.count} triangles, key={self.key[:12]})"


def holdout_depth(holdout: Holdout, camera: Camera, window=None) -> np.ndarray:
    """(H, W) float64: the depth of the nearest surface under each pixel centre, inf where
    none (module docstring). window (x, y, width, height): only that crop of the frame."""
    wx, wy, w, h = window if window is not None else (0, 0, camera.width, camera.height)
    out = np.full(h * w, np.inf)
    if holdout.count == 0:
        return out.reshape(h, w)
    m = np.asarray(camera.world_to_camera, np.float64)
    tri = holdout.triangles @ m[:3, :3].T + m[:3, 3]  # camera space, float64
    if camera.equirect:
        rects = _equirect_rects(tri, camera, (wx, wy, w, h))
    else:
        rects = _planar_rects(tri, camera, (wx, wy, w, h))
    for idx, x0, y0, bw, bh, nw, nh in _blocks(rects):
        _cast(tri[idx], x0, y0, bw, bh, nw, nh, camera, (wx, wy, w, h), out)
    return out.reshape(h, w)


def kept(splat_depth, holdout_at_pixels):
    """The per-fragment rule: True where a splat fragment of centre depth splat_depth is
    composited at pixels whose holdout depth is holdout_at_pixels (broadcasting)."""
    return np.asarray(splat_depth) < np.asarray(holdout_at_pixels)


def combine_depth(splat_depth, splat_alpha, mesh_depth, depth_from_alpha: float = 0.5):
    """The Z pass of a frame of splats and meshes.

    The splat layer has a depth where its Z is finite and its alpha (the splats' own,
    without background) is >= depth_from_alpha (0.5, the reference's rule; the splat Z
    is inf elsewhere already). There the combined Z is min(splat Z, mesh Z); elsewhere
    it is the mesh Z, with whatever value the mesh pass gives its background (inf, or
    Blender's 1e10). With the holdout every kept fragment lies in front of the surface,
    so where the splats have a depth it is theirs. Element-wise, float32 or 64 in, the
    mesh pass's dtype out."""
    sd = np.asarray(splat_depth)
    md = np.asarray(mesh_depth)
    has = np.isfinite(sd) & (np.asarray(splat_alpha) >= depth_from_alpha)
    return np.where(has, np.minimum(sd, md), md).astype(md.dtype)


def combine_alpha(splat_alpha, mesh_alpha):
    """Alpha of the combined frame: the splat layer (premultiplied, already held out) over
    the meshes, A = a_s + (1 - a_s) a_m. Colour goes the same way: C = C_s + (1 - a_s) C_m,
    both premultiplied and in the same colour space."""
    a = np.asarray(splat_alpha)
    return a + (1.0 - a) * np.asarray(mesh_alpha)


# ---- bounding rectangles: (triangle index, x0, x1, y0, y1) inclusive pixel ranges ----

def _pixel_range(lo, hi, start, size):
    """Inclusive pixel indices whose centres lie in [lo - margin, hi + margin], clipped
    to [start, start + size - 1] (floats clipped before the cast)."""
    a = np.ceil(np.clip(lo - _MARGIN - 0.5, start - 1, start + size))
    b = np.floor(np.clip(hi + _MARGIN - 0.5, start - 1, start + size))
    return np.maximum(a, start).astype(np.int64), np.minimum(b, start + size - 1).astype(np.int64)


def _planar_rects(tri, camera, window):
    """Screen boxes of the triangles' visible parts (perspective: clipped at the near
    plane first, so a triangle reaching behind the camera gets a finite box)."""
    wx, wy, w, h = window
    depth = -tri[..., 2]
    live = (depth.max(1) > camera.near) & (depth.min(1) <= camera.far)
    if camera.ortho:
        u = camera.cx + camera.fx * tri[..., 0]
        v = camera.cy - camera.fy * tri[..., 1]
    else:
        near = max(camera.near, 1e-12)
        inside = depth >= near
        with np.errstate(all="ignore"):
            pts = [np.where(inside[:, :, None], tri, np.nan)]
            for a, b in ((0, 1), (1, 2), (2, 0)):  # edge points on the near plane
                da, db = depth[:, a], depth[:, b]
                s = (near - da) / (db - da)
                p = tri[:, a] + s[:, None] * (tri[:, b] - tri[:, a])
                cross = (da >= near) != (db >= near)
                pts.append(np.where(cross[:, None], p, np.nan)[:, None])
            p = np.concatenate(pts, 1)
            u = camera.cx + camera.fx * p[..., 0] / -p[..., 2]
            v = camera.cy - camera.fy * p[..., 1] / -p[..., 2]
        live &= inside.any(1)
    with np.errstate(all="ignore"):  # nan: a corner clipped away
        x0, x1 = _pixel_range(np.fmin.reduce(u, 1), np.fmax.reduce(u, 1), wx, w)
        y0, y1 = _pixel_range(np.fmin.reduce(v, 1), np.fmax.reduce(v, 1), wy, h)
    live &= (x0 <= x1) & (y0 <= y1)
    idx = np.nonzero(live)[0]
    return idx, x0[idx], x1[idx], y0[idx], y1[idx]


def _equirect_rects(tri, camera, window):
    """Longitude/latitude boxes from each triangle's bounding cone of directions (a cap
    under 90 degrees holds the spherical triangle its corners span); the whole window
    where the cone is wider or reaches a pole. Boxes wrap the +-180 degree seam as
    shifted copies."""
    wx, wy, w, h = window
    dist = np.linalg.norm(tri, axis=2)
    live = dist.max(1) > camera.near  # a corner at the camera: no cone, the whole window
    with np.errstate(all="ignore"):
        unit = tri / dist[..., None]
        axis = unit.sum(1)
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        cos_half = np.einsum("tkc,tc->tk", unit, axis).min(1)
        half = np.arccos(np.clip(cos_half, -1.0, 1.0)) + 1e-9
        lam = np.arctan2(axis[:, 0], -axis[:, 2])
        phi = np.arctan2(axis[:, 1], np.hypot(axis[:, 0], axis[:, 2]))
        dlam = np.arcsin(np.clip(np.sin(half) / np.cos(phi), -1.0, 1.0))
    cone = np.isfinite(cos_half) & (half < 0.5 * np.pi - 1e-6)
    bounded = cone & (np.abs(phi) + half < 0.5 * np.pi - 1e-6)
    full = ~bounded
    lat_hi = np.where(cone, phi + half, 0.5 * np.pi)
    lat_lo = np.where(cone, phi - half, -0.5 * np.pi)
    y0, y1 = _pixel_range(camera.cy - camera.fy * lat_hi, camera.cy - camera.fy * lat_lo, wy, h)
    parts = []
    for k in (0, -1, 1):  # the box, then its copies one turn over (bounded boxes only)
        shift = 2.0 * np.pi * k
        lo = np.where(full, -np.inf, lam - dlam + shift)
        hi = np.where(full, np.inf, lam + dlam + shift)
        x0, x1 = _pixel_range(camera.cx + camera.fx * lo, camera.cx + camera.fx * hi, wx, w)
        ok = live & (x0 <= x1) & (y0 <= y1) & (bounded if k else True)
        i = np.nonzero(ok)[0]
        parts.append((i, x0[i], x1[i], y0[i], y1[i]))
    return tuple(np.concatenate(c) for c in zip(*parts))


def _blocks(rects):
    """Cut rectangles into blocks of at most 64 x 64, group them by padded size and yield
    (triangle indices, x0, y0, padded w, padded h, true w, true h) chunks."""
    idx, x0, x1, y0, y1 = rects
    if idx.size == 0:
        return
    nbx = (x1 - x0) // _BLOCK + 1
    nby = (y1 - y0) // _BLOCK + 1
    reps = nbx * nby
    t = np.repeat(np.arange(idx.size), reps)
    k = np.arange(t.size) - np.repeat(np.cumsum(reps) - reps, reps)
    bx0 = x0[t] + (k % nbx[t]) * _BLOCK
    by0 = y0[t] + (k // nbx[t]) * _BLOCK
    bw = np.minimum(x1[t] - bx0 + 1, _BLOCK)
    bh = np.minimum(y1[t] - by0 + 1, _BLOCK)
    pw = _SIZES[np.searchsorted(_SIZES, bw)]
    ph = _SIZES[np.searchsorted(_SIZES, bh)]
    key = ph * 1000 + pw
    order = np.argsort(key, kind="stable")
    bounds = np.flatnonzero(np.diff(key[order])) + 1
    for group in np.split(order, bounds):
        gw, gh = int(pw[group[0]]), int(ph[group[0]])
        step = max(1, _CHUNK // (gw * gh))
        for s in range(0, group.size, step):
            g = group[s:s + step]
            yield idx[t[g]], bx0[g], by0[g], gw, gh, bw[g], bh[g]


def _rays(px, py, camera):
    """Pixel centres (camera frame coordinates) -> ray origins, directions (camera space)
    and whether the origin is the camera centre. Hit parameter t = depth."""
    a = (px - camera.cx) / camera.fx
    b = (camera.cy - py) / camera.fy
    if camera.equirect:  # a, b: longitude, latitude; unit directions, t = distance
        cb = np.cos(b)
        return None, (cb * np.sin(a), np.sin(b), -cb * np.cos(a))
    if camera.ortho:     # parallel rays from the image plane, t = -z
        return (a, b), (0.0, 0.0, -1.0)
    return None, (a, b, -np.ones_like(a))


def _cast(tri, x0, y0, pw, ph, nw, nh, camera, window, out):
    """Moeller-Trumbore for n triangles over their (ph, pw) padded blocks; min into out."""
    wx, wy, w, h = window
    jx = np.arange(pw)[None, None, :]
    jy = np.arange(ph)[None, :, None]
    inside = (jx < nw[:, None, None]) & (jy < nh[:, None, None])
    px = np.broadcast_to(x0[:, None, None] + jx, inside.shape)
    py = np.broadcast_to(y0[:, None, None] + jy, inside.shape)
    origin, (dx, dy, dz) = _rays(px + 0.5, py + 0.5, camera)
    v0, e1, e2 = (tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    v0, e1, e2 = ([c[:, i, None, None] for i in range(3)] for c in (v0, e1, e2))
    with np.errstate(all="ignore"):
        p = (dy * e2[2] - dz * e2[1], dz * e2[0] - dx * e2[2], dx * e2[1] - dy * e2[0])
        det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2]
        inv = 1.0 / det
        if origin is None:
            s = (-v0[0], -v0[1], -v0[2])
        else:
            s = (origin[0] - v0[0], origin[1] - v0[1], -v0[2])
        u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) * inv
        q = (s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0])
        v = (dx * q[0] + dy * q[1] + dz * q[2]) * inv
        t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) * inv
        hit = (inside & (det != 0.0) & (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0)
               & (t > camera.near) & (t > 0.0) & (t <= camera.far))
    flat = (py[hit] - wy) * w + (px[hit] - wx)
    np.minimum.at(out, flat, t[hit])
