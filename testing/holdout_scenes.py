"""Splats and meshes in one frame: the scenes the holdout tests share.

`guitar_scene` is the real-capture scene every renderer's holdout test uses (core
reference, the moderngl renderer, the Blender engine): guitar.ply with its RDF axes as
the object rotation, a camera that sees the whole guitar lying across the frame, and
three opaque surfaces:
- "front_cube": a cube between the camera and the guitar's body, covering part of it;
  behind it only splats nearer than the cube survive (hardly any);
- "back_cube": a cube behind the guitar, half hidden by it: it changes nothing where
  the guitar is opaque;
- "plane": a rectangle through the guitar's middle, tilted against the view, over the
  neck's half of the frame: per fragment it hides only the splats behind it.
Everything is in world space (identity object matrices for the meshes). `meshes`
gives each surface as vertices and quad faces (Blender: `mesh.from_pydata(verts, [],
faces)`), `triangles` the same triangulated, `holdout` all three as one Holdout.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from addon.core import formats
from addon.core.axes import matrix_for
from addon.core.camera import Camera, look_at, simple_camera
from addon.core.holdout import Holdout
from addon.core.scene import RenderItem

# the guitar's body is at the low z end of its long (world z) axis, the neck at the high end
VIEW = np.array([0.25, -1.0, 0.15])  # camera -> guitar, roughly: a slightly turned front view


@dataclass
class HoldoutScene:
    items: list          # [RenderItem]: the guitar
    camera: Camera
    holdout: Holdout     # every surface below, together
    meshes: dict         # name -> (verts (V, 3) float64 world, faces [tuple of 4 indices])
    triangles: dict      # name -> (T, 3, 3) float64 world triangles of that mesh
    centre: np.ndarray   # the guitar's middle (world)
    size: float          # its 2-98 percentile box diagonal


def triangulate(verts, faces) -> np.ndarray:
    """(T, 3, 3) triangles of quad/triangle faces (fans from each face's first corner)."""
    v = np.asarray(verts, np.float64)
    tris = [(f[0], f[k], f[k + 1]) for f in faces for k in range(1, len(f) - 1)]
    return np.ascontiguousarray(v[np.array(tris)])


def box_mesh(centre, half, rotation=np.eye(3)):
    """A box: centre, half extents (3,), rotated by `rotation` (3x3). Outward quads."""
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64)
    verts = (corners * np.asarray(half, np.float64)) @ np.asarray(rotation, np.float64).T + centre
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return verts, faces


def quad_mesh(centre, axis_u, axis_v):
    """A rectangle centre +- axis_u +- axis_v (one quad face)."""
    c, a, b = (np.asarray(x, np.float64) for x in (centre, axis_u, axis_v))
    return np.array([c - a - b, c + a - b, c + a + b, c - a + b]), [(0, 1, 2, 3)]


def read_guitar(testdata, every: int = 1):
    """guitar.ply (every `every`-th splat) as imported: RenderItem with the RDF axes rotation."""
    sp = formats.read(testdata / "guitar.ply")
    if every > 1:
        sp = sp.subset(np.arange(0, sp.count, every))
    world = np.eye(4)
    world[:3, :3] = matrix_for(sp.axes)
    return RenderItem(sp, world=world, key=("guitar", every))


def guitar_scene(testdata, width: int = 96, height: int = 64, every: int = 1) -> HoldoutScene:
    """The guitar, a camera, and the front cube, back cube and tilted plane (module doc).

    testdata: the folder holding guitar.ply (tests' `testdata` fixture). every: keep every
    n-th splat (1: all 90854; the reference takes ~5 s per 96x64 frame with all)."""
    item = read_guitar(testdata, every)
    pos = item.splats.positions.astype(np.float64) @ item.world[:3, :3].T + item.world[:3, 3]
    lo, hi = np.percentile(pos, [2, 98], axis=0)  # the capture, not its stray splats
    centre, size = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo))
    view = VIEW / np.linalg.norm(VIEW)
    eye = centre - view * 1.25 * size
    # up = world x: the guitar's long axis (world z) runs across the wide frame
    camera = simple_camera(width, height, 50.0, look_at(eye, centre, up=(1.0, 0.0, 0.0)),
                           near=0.01 * size, far=100.0 * size)
    along = np.array([0.0, 0.0, 1.0])                       # the guitar's long axis
    side = np.cross(view, along)
    side /= np.linalg.norm(side)
    body = centre - 0.28 * size * along                      # the body's middle, about
    meshes = {
        # a third of the way to the camera, over one edge of the body
        "front_cube": box_mesh(body + 0.35 * size * (-view) + 0.06 * size * side,
                               np.full(3, 0.06 * size)),
        # behind the guitar, its left half behind the body's edge
        "back_cube": box_mesh(body + 0.3 * size * view - 0.12 * size * side,
                              np.full(3, 0.09 * size)),
        # through the middle, over the neck's half, turned 35 degrees against the view
        "plane": quad_mesh(centre + 0.3 * size * along,
                           0.3 * size * along,
                           0.4 * size * (np.cos(np.radians(35)) * side
                                         + np.sin(np.radians(35)) * view)),
    }
    triangles = {name: triangulate(*m) for name, m in meshes.items()}
    holdout = Holdout(np.concatenate(list(triangles.values())))
    return HoldoutScene([item], camera, holdout, meshes, triangles, centre, size)
