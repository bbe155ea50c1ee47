"""The stored source: an object's splats are its own PointCloud attributes (Splatline's
imports and Blender 5.3's own), read through a cache (its row of the source table,
sources.py, is `ROW`).
"""
from __future__ import annotations

import threading

import numpy as np

import bpy

from ...core.splats import ARRAYS
from .evaluated_geometry import handoff_modifier, own_data
from .pointcloud import BASE, is_splat_data, splats_from_pointcloud, value_key
from .source_kind import SourceFrame, SplatSource


def _sample(pointcloud, count: int, samples: int = 16) -> tuple:
    """A few values of the centres and colours, spread over the points (~0.15 ms): catches
    data replaced or rewritten without a depsgraph update we could see."""
    if count == 0:
        return ()
    index = np.unique(np.linspace(0, count - 1, samples).astype(np.int64))
    out = []
    for name in ("position", BASE):
        attribute = pointcloud.attributes.get(name)
        if attribute is not None:
            field = value_key(attribute)
            data = attribute.data
            out.extend(tuple(getattr(data[int(i)], field)) for i in index)
    return tuple(out)


class BaseCache:
    """SplatSets read from evaluated PointClouds, keyed by what makes them change.

    The key holds the data's name and point count, a version bumped by every depsgraph
    update that reports the PointCloud's geometry changed, and a sample of its values
    (for data replaced without an update we could see). Animated objects count too:
    measured (bpy 5.0), frame changes send no depsgraph_update_post, so playback re-reads
    nothing, while an edit of the data sends one. Objects sharing one PointCloud without
    modifiers (linked duplicates) share one entry; objects with modifiers have their own,
    also keyed by frame. Cached arrays are read-only: kernels and renderers never write them.

    The viewport (main thread) and a render thread share one cache: `lock` guards the
    dicts. bpy is read only outside it, by the thread that asked (each reads its own
    depsgraph), so a slow read never blocks the other thread's hits.
    """

    def __init__(self):
        self.lock = threading.Lock()
        self.versions: dict[str, int] = {}
        self.entries: dict[tuple, tuple] = {}

    def key(self, obj_eval, depsgraph) -> tuple:
        original = obj_eval.original
        data = own_data(obj_eval, depsgraph)
        data_name = data.original.name_full
        count = len(data.points)
        # with a handoff (5.3+) the object's own data is read, before any modifier
        modified = len(original.modifiers) > 0 and handoff_modifier(original) is None
        slot = ("object", original.name_full) if modified else ("data", data_name)
        frame = depsgraph.scene_eval.frame_float if modified else None
        with self.lock:
            version = self.versions.get(data_name, 0)
        return (slot, data_name, version, count, frame, hash(_sample(data, count)))

    def get(self, obj_eval, depsgraph):
        key = self.key(obj_eval, depsgraph)
        with self.lock:
            hit = self.entries.get(key[0])
        if hit is None or hit[0] != key:
            splats = splats_from_pointcloud(own_data(obj_eval, depsgraph))
            for name in ARRAYS:
                getattr(splats, name).flags.writeable = False
            hit = (key, splats)
            with self.lock:
                self.entries[key[0]] = hit
            self.prune()
        return hit[1], hit[0]

    def prune(self) -> None:
        """Let the data of deleted objects and PointClouds go (1M splats hold ~250 MB)."""
        alive = {("object", o.name_full) for o in bpy.data.objects}  # only after a read: rare
        alive |= {("data", d.name_full) for d in bpy.data.pointclouds}
        with self.lock:
            for slot in [s for s in self.entries if s not in alive]:
                del self.entries[slot]

    def on_update(self, depsgraph) -> None:
        changed = [u.id.original.name_full for u in depsgraph.updates
                   if isinstance(u.id, bpy.types.PointCloud) and u.is_updated_geometry]
        with self.lock:
            for name in changed:
                self.versions[name] = self.versions.get(name, 0) + 1

    def clear(self) -> None:
        with self.lock:
            self.entries.clear()
            self.versions.clear()


CACHE = BaseCache()


def holds_splats(obj) -> bool:
    """The object's data holds splat attributes. An evaluated object with a handoff (Blender
    5.3+) shows its companion's geometry, which holds no attributes while it hides every
    splat: the object's own data decides then."""
    return is_splat_data(obj.data) or is_splat_data(obj.original.data)


def _source_frame(obj_eval, depsgraph) -> SourceFrame:
    splats, key = CACHE.get(obj_eval, depsgraph)
    return SourceFrame(splats, key)


ROW = SplatSource("STORED", "Stored Splats", holds_splats, _source_frame,
                  depends_on_time=False, moves_splats=False, stored=True)
