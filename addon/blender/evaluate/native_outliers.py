"""What Blender 5.3's own engines get of each capture: its splats but the few far outliers
(core/far_outliers.py), decided once per data version, so that scrubbing and rendering
frames reuse the decision and the handoff still writes only what changed.

The data version is the source's base key (item.base_key: the object and its source
frame's key), so an edit of the splats, another sequence frame or another capture time
decides again; look, crop and effects do not."""
from __future__ import annotations

import sys
from collections import OrderedDict

from ...core import far_outliers
from ..data.evaluated_geometry import own_data
from ..data.pointcloud import read_positions
from ..data.sources import source_of
from ..data.stored_splats import CACHE


def wanted(depsgraph) -> bool:
    """The scene's Render > Leave Out Far Outliers (the original scene's: its evaluated copy
    may not have seen the change yet)."""
    settings = getattr(depsgraph.scene, "splatline", None)
    return bool(getattr(getattr(settings, "render", None), "native_outliers", False))


class KeptSets:
    """FarOutliers by data version, the last `size` of them. Not locked: the handoff calls
    it under its own lock."""

    def __init__(self, size: int = 64):
        self.size = size
        self.entries: OrderedDict[tuple, far_outliers.FarOutliers] = OrderedDict()
        self.found = 0  # how many decisions were computed (tests: once per data version)

    def for_stored(self, obj_eval, depsgraph) -> far_outliers.FarOutliers:
        """An object whose splats are its stored ones: its centres alone are read, and only
        the first time its data version is seen (it may have no companion yet)."""
        key = (obj_eval.original.name_full, CACHE.key(obj_eval, depsgraph))
        return self._get(key, obj_eval.original.name_full,
                         lambda: read_positions(own_data(obj_eval, depsgraph)))

    def for_item(self, obj_eval, depsgraph, item) -> far_outliers.FarOutliers:
        """An evaluated item: decided on its source's splats before effects (they may move
        them), the centres the item's own are when nothing moved them."""
        def positions():
            if item.positions_key == item.base_key:
                return item.splats.positions
            return source_of(obj_eval).frame(obj_eval, depsgraph).splats.positions
        found = self._get(item.base_key, obj_eval.original.name_full, positions)
        if found.kept is not None and len(item.splats.positions) != found.count:
            return far_outliers.FarOutliers(None, found.count, found.far, 0, found.reach)
        return found

    def _get(self, key, name, positions) -> far_outliers.FarOutliers:
        hit = self.entries.get(key)
        if hit is not None:
            self.entries.move_to_end(key)
            return hit
        hit = far_outliers.find(positions())
        self.found += 1
        _report(name, hit)
        self.entries[key] = hit
        while len(self.entries) > self.size:
            self.entries.popitem(last=False)
        return hit

    def clear(self) -> None:
        self.entries.clear()


def _report(name: str, found: far_outliers.FarOutliers) -> None:
    if found.dropped:
        print(f"Splatline: {found.dropped} far outlier splat(s) of {name!r} left out of Blender's "
              f"engines (beyond {found.reach:.3g} from the capture's middle; Render Properties > "
              "Leave Out Far Outliers)", file=sys.stderr)
    elif found.far:
        print(f"Splatline: {name!r} has {found.far} far splats, too many to be outliers: all are "
              "handed to Blender's engines", file=sys.stderr)
