"""The opaque surfaces a render depsgraph shows, as world-space triangles: what hides splats.

`holdout_for(depsgraph)` gives core.holdout.Holdout for the frame the depsgraph holds (None
where nothing is there), which the render engine puts in RenderOptions.holdout.

What counts as a surface: every object instance the depsgraph iterates (so only what the
render sees: hide_render, excluded and render-disabled collections, the view layer) whose
object is a MESH, CURVE, SURFACE, META or FONT, read as its evaluated mesh (modifiers,
shape keys, armatures, geometry nodes), at the instance's world matrix (collection
instances, vertex/face instancing and geometry-nodes instances come as instances). Left out:
splat objects and their Blender 5.3 handoff companions (POINTCLOUDs anyway), cameras,
lights, empties, hair curves, volumes, grease pencil, objects with Visibility > Ray
Visibility > Camera off, and objects in an Indirect Only collection of the view layer (Cycles
shows them only through their light). Objects set to Holdout still hide splats: they are
opaque surfaces that Blender renders as holes.

Cost and caching: each surface's vertex positions and triangle indices are read with
foreach_get every frame (a copy of the evaluated mesh's arrays). Where both and the world
matrix are byte-identical to the same instance's last read, the world-space triangles are
reused; where every part is reused, so is the last Holdout (no new hash, a renderer's
upload keyed by it stays valid). The comparison is exact, so the result depends only on the
frame being rendered: frame 2 alone equals frame 2 in a range, bit for bit.
"""
from __future__ import annotations

import threading

import numpy as np

from ...core.holdout import Holdout
from ..data.pointcloud import COMPANION_MARK

SURFACE_TYPES = frozenset({"MESH", "CURVE", "SURFACE", "META", "FONT"})


def is_surface(obj) -> bool:
    """An object type whose geometry hides splats (and is drawn in the mesh layer)."""
    return obj is not None and obj.type in SURFACE_TYPES and COMPANION_MARK not in obj.keys()


def _seen_by_camera(obj, source, view_layer) -> bool:
    if not getattr(obj, "visible_camera", True):
        return False
    original = getattr(source, "original", source)
    try:
        return not original.indirect_only_get(view_layer=view_layer)
    except (AttributeError, RuntimeError, TypeError, ReferenceError):
        return True  # not in this view layer's bases (an instanced object): as its instancer


def _mesh_arrays(obj):
    """(positions (V, 3) float32, triangle vertex indices (T, 3) int32) of the evaluated
    object's mesh, object space."""
    if obj.type == "MESH":
        return _arrays(obj.data)
    mesh = obj.to_mesh()
    try:
        return _arrays(mesh) if mesh is not None else _empty()
    finally:
        obj.to_mesh_clear()


def _empty():
    return np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32)


def _arrays(mesh):
    tris = mesh.loop_triangles
    if len(tris) == 0 or len(mesh.vertices) == 0:
        return _empty()
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    idx = np.empty(len(tris) * 3, np.int32)
    tris.foreach_get("vertices", idx)
    return co.reshape(-1, 3), idx.reshape(-1, 3)


class _Part:
    __slots__ = ("co", "idx", "matrix", "world")

    def __init__(self, co, idx, matrix):
        self.co, self.idx, self.matrix = co, idx, matrix
        m = matrix.astype(np.float64)
        points = co.astype(np.float64) @ m[:3, :3].T + m[:3, 3]
        self.world = points[idx]  # (T, 3, 3) float64

    def same(self, co, idx, matrix) -> bool:
        return (np.array_equal(self.matrix, matrix) and np.array_equal(self.co, co)
                and np.array_equal(self.idx, idx))


class HoldoutCache:
    """World triangles per object instance, reused while its arrays and matrix are unchanged.

    Keyed by (object name, library, instancer name, persistent instance id); a key not seen
    in a frame is dropped after it, so the cache holds one frame's surfaces."""

    def __init__(self):
        self._lock = threading.Lock()
        self._parts: dict = {}
        self._keys: tuple = ()
        self._holdout = None

    def holdout(self, depsgraph):
        view_layer = depsgraph.view_layer
        parts, keys = {}, []
        reused = True
        with self._lock:
            for key, obj, matrix in _surface_instances(depsgraph, view_layer):
                co, idx = _mesh_arrays(obj)
                if idx.size == 0:
                    continue
                part = self._parts.get(key)
                if part is None or not part.same(co, idx, matrix):
                    part, reused = _Part(co, idx, matrix), False
                parts[key] = part
                keys.append(key)
            keys = tuple(keys)
            if reused and keys == self._keys and self._holdout is not None:
                return self._holdout
            self._parts, self._keys = parts, keys
            if not keys:
                self._holdout = None
                return None
            self._holdout = Holdout(np.concatenate([parts[k].world for k in keys]))
            return self._holdout

    def clear(self):
        with self._lock:
            self._parts, self._keys, self._holdout = {}, (), None


def _surface_instances(depsgraph, view_layer):
    """(cache key, evaluated object, (4, 4) float32 world matrix) of every surface instance."""
    seen = {}
    for inst in depsgraph.object_instances:
        obj = inst.object
        if not is_surface(obj):
            continue
        source = inst.parent if inst.is_instance and inst.parent is not None else obj
        if not _seen_by_camera(obj, source, view_layer):
            continue
        if inst.is_instance:
            key = ("instance", obj.name_full, inst.parent.name_full if inst.parent else "",
                   tuple(inst.persistent_id))
        else:
            key = ("object", obj.name_full)
        n = seen.get(key, 0)  # two instances with one key (never expected): keep both
        seen[key] = n + 1
        matrix = np.array(inst.matrix_world, np.float32)
        yield (key, n), obj, matrix


_CACHE = HoldoutCache()


def holdout_for(depsgraph):
    """core Holdout of the surfaces the depsgraph shows at its frame, or None."""
    return _CACHE.holdout(depsgraph)


def holdout_triangles(depsgraph) -> np.ndarray:
    """(T, 3, 3) float64 world-space triangles, uncached (tests, tools)."""
    view_layer = depsgraph.view_layer
    parts = [_Part(*_mesh_arrays(obj), matrix).world
             for _, obj, matrix in _surface_instances(depsgraph, view_layer)]
    parts = [p for p in parts if len(p)]
    return np.concatenate(parts) if parts else np.zeros((0, 3, 3))


def clear_cache():
    _CACHE.clear()
