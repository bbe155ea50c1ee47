"""Shadows on splats (issue 43): how much of each light reaches each splat's centre, in [0, 1].
Pure numpy, float64.

Meshes (`Holdout` triangles, the surfaces the holdout already reads) cast exact shadows: the
segment from a splat's centre to the light (towards -direction for a sun) is ray-cast against
the triangles in float64 (Moeller-Trumbore, both faces, edges inclusive), and any hit further
than `bias` from the centre blocks the light. Fast path: the centres and the triangles are
projected into the light's view (an orthographic plane for a sun; for a light at a point, the
six faces of a cube around it), the centres binned in a grid, and each triangle tested only
against the centres in the cells its projection's box covers; a triangle wholly behind a cube
face's plane (through the light) is skipped for that face, and one that crosses it is tested
against all of that face's centres. Same tests, same float64, so the
fast path gives the brute-force reference's answer exactly (`mesh_visibility_reference`).

Splats shadow splats through their opacity seen from the light, a transmittance map: the
centres are binned in the same light-space grid, with cells of `cell` world units at the
splats' typical distance; in each cell, a splat's light passes the splats nearer the light
by more than `depth_bias` (so the splats of one surface do not shade each other), each
letting 1 - a through, a its opacity times the share of the cell its Gaussian covers
(2 pi s1 s2 / cell^2, s1 s2 its two larger scales, at most 1). What is approximate: a splat
shadows only its own cell (a splat larger than a cell shadows too little around it), and
the map is as coarse as its cells.
"""
from __future__ import annotations

import numpy as np

from .lights import Light

_FACES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], np.float64)
_EPS = 1e-12


def light_visibility(points, light: Light, triangles=None, splats=None, world=None,
                     cell: float | None = None) -> np.ndarray:
    """(N,) float32: the light's share reaching each world-space centre. triangles: (T, 3, 3)
    world-space (a Holdout's), or None; splats + world: the splats whose opacity shades (their
    centres are `points`), or None. A light with Cast Shadow off reaches every splat."""
    pts = np.asarray(points, np.float64)
    vis = np.ones(len(pts))
    if not light.shadow or len(pts) == 0:
        return vis.astype(np.float32)
    views = _views(pts, light)  # the light's view of the centres, once for both casters
    if triangles is not None and len(triangles):
        vis *= mesh_visibility(pts, light, triangles, views=views)
    if splats is not None:
        vis *= splat_transmittance(pts, splats, world, light, cell, views=views)
    return vis.astype(np.float32)


def _basis(axis: np.ndarray) -> np.ndarray:
    """(3, 3) rows u, v, axis: an orthonormal frame around a unit axis."""
    helper = np.array([1.0, 0, 0]) if abs(axis[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    return np.stack([u, np.cross(axis, u), axis])


def _views(pts: np.ndarray, light: Light):
    """[(indices of the centres, their 2D light-space coordinates, a function that projects
    (M, 3) world points to 2D, or None where a point cannot be projected)] per view."""
    if light.kind == "SUN":
        frame = _basis(light.direction_array / np.linalg.norm(light.direction_array))[:2]
        return [(np.arange(len(pts)), pts @ frame.T, lambda q: q @ frame.T)]
    centre = light.position_array
    rel = pts - centre
    dominant = np.argmax(np.abs(rel), axis=1)
    face = dominant * 2 + (rel[np.arange(len(rel)), dominant] < 0)  # _FACES' order
    views = []
    for f, axis in enumerate(_FACES):
        idx = np.flatnonzero(face == f)
        if len(idx) == 0:
            continue
        frame = _basis(axis)

        def project(q, frame=frame):
            r = (np.asarray(q, np.float64) - centre) @ frame.T
            w = r[..., 2]
            ok = w > _EPS
            return np.where(ok[..., None], r[..., :2] / np.where(ok, w, 1.0)[..., None], np.nan)
        views.append((idx, np.nan_to_num(project(pts[idx])), project))  # a centre at the light: 0
    return views


def _ray_hits(origins, ends, tri, bias) -> np.ndarray:
    """(M,) bool: the segments origins -> ends hit the triangle further than bias from their
    origin (Moeller-Trumbore, float64, both faces, edges inclusive)."""
    d = ends - origins
    length = np.linalg.norm(d, axis=1)
    d = d / np.where(length > 0, length, 1.0)[:, None]
    e1, e2 = tri[1] - tri[0], tri[2] - tri[0]
    p = np.cross(d, e2)
    det = p @ e1
    ok = np.abs(det) > _EPS
    inv = 1.0 / np.where(ok, det, 1.0)
    s = origins - tri[0]
    u = np.einsum("ij,ij->i", s, p) * inv
    q = np.cross(s, e1)
    v = np.einsum("ij,ij->i", d, q) * inv
    t = (q @ e2) * inv
    return ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > bias) & (t < length - bias)


def _segments_end(pts: np.ndarray, light: Light, far: float) -> np.ndarray:
    if light.kind == "SUN":
        towards = -light.direction_array / np.linalg.norm(light.direction_array)
        return pts + far * towards
    return np.broadcast_to(light.position_array, pts.shape)


def _reach(pts, triangles) -> float:
    span = np.ptp(np.concatenate([pts, triangles.reshape(-1, 3)]), axis=0)
    return float(np.linalg.norm(span)) * 4.0 + 1.0


def mesh_visibility_reference(points, light: Light, triangles, bias: float | None = None) -> np.ndarray:
    """Every centre against every triangle: the readable reference of mesh_visibility."""
    pts, tris, ends, bias = _segments(points, light, triangles, bias)
    lit = np.ones(len(pts), bool)
    for tri in tris:
        lit &= ~_ray_hits(pts, ends, tri, bias)
    return lit.astype(np.float64)


def _segments(points, light: Light, triangles, bias):
    """(centres, triangles, the segments' far ends, bias), float64. The default bias is a
    millionth of the scene's size: a splat lying on a mesh is not shadowed by it."""
    pts = np.asarray(points, np.float64)
    tris = np.asarray(triangles, np.float64)
    reach = _reach(pts, tris)
    return pts, tris, _segments_end(pts, light, reach), 1e-6 * reach if bias is None else bias


def mesh_visibility(points, light: Light, triangles, bias: float | None = None, views=None) -> np.ndarray:
    """(N,) 0 or 1: whether the light reaches each centre past the triangles."""
    pts, tris, ends, bias = _segments(points, light, triangles, bias)
    lit = np.ones(len(pts), bool)
    for idx, uv, project in _views(pts, light) if views is None else views:
        grid = _Grid(uv)
        tri_uv = project(tris.reshape(-1, 3)).reshape(len(tris), 3, 2)
        for t, corners in enumerate(tri_uv):
            behind = np.isnan(corners[:, 0])
            if behind.all():  # behind this face's plane: no segment to its centres meets it
                continue
            if behind.any():  # crosses the plane: every centre of the face
                cand = np.arange(len(idx))
            else:
                cand = grid.inside(corners.min(axis=0), corners.max(axis=0))
            sel = idx[cand]
            sel = sel[lit[sel]]  # a centre already in shadow needs no more tests
            if len(sel):
                lit[sel] = ~_ray_hits(pts[sel], ends[sel], tris[t], bias)
    return lit.astype(np.float64)


class _Grid:
    """2D points binned in a square grid of about 4 points a cell (at most 1024 a side)."""

    def __init__(self, uv: np.ndarray):
        self.lo = uv.min(axis=0)
        span = np.maximum(uv.max(axis=0) - self.lo, _EPS)
        self.side = int(np.clip(np.sqrt(len(uv) / 4.0), 1, 1024))
        self.size = span / self.side
        cell = self._cells(uv)
        key = cell[:, 1] * self.side + cell[:, 0]
        self.order = np.argsort(key, kind="stable")
        self.starts = np.searchsorted(key[self.order], np.arange(self.side * self.side + 1))

    def _cells(self, uv):
        return np.clip(((uv - self.lo) / self.size).astype(np.int64), 0, self.side - 1)

    def inside(self, lo, hi) -> np.ndarray:
        """Indices of the points in the cells the box [lo, hi] touches (a superset)."""
        if (hi < self.lo).any() or (lo > self.lo + self.size * self.side).any():
            return np.zeros(0, np.int64)
        (x0, y0), (x1, y1) = self._cells(lo[None])[0], self._cells(hi[None])[0]
        rows = [self.order[self.starts[y * self.side + x0]:self.starts[y * self.side + x1 + 1]]
                for y in range(y0, y1 + 1)]
        return np.concatenate(rows) if rows else np.zeros(0, np.int64)


def splat_transmittance(points, splats, world, light: Light, cell: float | None = None,
                        depth_bias: float | None = None, views=None) -> np.ndarray:
    """(N,) the light's share that passes the other splats to each centre (see the module)."""
    pts = np.asarray(points, np.float64)
    alpha, cell, depth_bias = _occluding(splats, world, cell, depth_bias)
    log_pass = np.log1p(-alpha)
    out = np.ones(len(pts))
    for idx, uv, depth, size in _light_cells(pts, light, cell, views):
        out[idx] = _passing(uv, depth, log_pass[idx], size, depth_bias)
    return out


def _occluding(splats, world, cell, depth_bias):
    """(each splat's opacity share of a cell, at most 0.999; the cell; the depth bias)."""
    scales = np.sort(np.asarray(splats.scales, np.float64), axis=1)
    if world is not None:
        scales = scales * _size_of(world)
    if cell is None:
        cell = 4.0 * float(np.median(scales[:, 2])) if len(scales) else 1.0
    if not cell > 0.0:  # splats of no size (or an object shrunk to a point) shade nothing
        return np.zeros(len(scales)), 1.0, 2.0 if depth_bias is None else depth_bias
    depth_bias = 2.0 * cell if depth_bias is None else depth_bias
    alpha = np.asarray(splats.opacities, np.float64) * np.minimum(
        1.0, 2 * np.pi * scales[:, 1] * scales[:, 2] / (cell * cell))
    return np.minimum(alpha, 0.999), cell, depth_bias


def _size_of(world) -> float:
    """How much the world matrix scales a splat: the cube root of its volume change, or, for
    a flattened object (scaled to 0 along an axis), the mean of the sizes it keeps."""
    sizes = np.linalg.svd(np.asarray(world, np.float64)[:3, :3], compute_uv=False)
    kept = sizes[sizes > 1e-12 * sizes[0]] if sizes[0] > 0 else sizes[:0]
    if len(kept) == 3:
        return float(np.cbrt(np.prod(kept)))
    return float(kept.mean()) if len(kept) else 0.0


def _light_cells(pts, light: Light, cell: float, views=None):
    """Per light view (`_views`' own, or computed here): (indices, 2D coordinates, depth from
    the light, the cell in the view's units: a sun's plane keeps world units, a cube face's
    are tangents)."""
    for idx, uv, _ in _views(pts, light) if views is None else views:
        if light.kind == "SUN":
            yield idx, uv, pts[idx] @ (light.direction_array / np.linalg.norm(light.direction_array)), cell
        else:
            depth = np.linalg.norm(pts[idx] - light.position_array, axis=1)
            yield idx, uv, depth, cell / max(float(np.median(depth)), _EPS)


def _passing(uv, depth, log_pass, size, depth_bias) -> np.ndarray:
    """exp(sum of log_pass of the points in the same cell nearer than depth - depth_bias)."""
    cells = np.floor((uv - uv.min(axis=0)) / size).astype(np.int64)
    width = int(cells[:, 0].max()) + 1
    cell_id = cells[:, 1] * width + cells[:, 0]
    lo, span = float(depth.min()), float(np.ptp(depth)) + depth_bias + 1.0
    key = cell_id * 2.0 + (depth - lo) / span                 # cell, then depth, in one key
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    prefix = np.concatenate([[0.0], np.cumsum(log_pass[order])])
    start = np.searchsorted(sorted_key, cell_id * 2.0, side="left")
    query = cell_id * 2.0 + np.maximum(depth - depth_bias - lo, 0.0) / span
    upto = np.searchsorted(sorted_key, query, side="left")
    return np.exp(prefix[upto] - prefix[start])


def splat_transmittance_reference(points, splats, world, light: Light, cell: float | None = None,
                                  depth_bias: float | None = None) -> np.ndarray:
    """The same map, one centre at a time: the product of 1 - a over the splats in its cell
    nearer the light by more than depth_bias (a reference for small sets)."""
    pts = np.asarray(points, np.float64)
    alpha, cell, depth_bias = _occluding(splats, world, cell, depth_bias)
    out = np.ones(len(pts))
    for idx, uv, depth, size in _light_cells(pts, light, cell):
        cells = np.floor((uv - uv.min(axis=0)) / size).astype(np.int64)
        for a in range(len(idx)):
            same = (cells == cells[a]).all(axis=1) & (depth < depth[a] - depth_bias)
            out[idx[a]] = float(np.prod(1.0 - alpha[idx][same]))
    return out
