"""Evaluated splat objects -> RenderItems: the one place the viewport and the engine get data.

v1: reads the evaluated PointCloud (so modifiers apply) and the world matrix. The animation
layer adds look properties, the effect stack and sequences here.
"""
from __future__ import annotations

import numpy as np

from ..core.scene import RenderItem
from . import sequence_runtime
from .pointcloud import is_splat_data, splats_from_pointcloud


def is_splat_object(obj) -> bool:
    return obj is not None and obj.type == "POINTCLOUD" and is_splat_data(obj.data)


def splat_objects(depsgraph):
    """Evaluated splat objects that the depsgraph considers visible (view layer, collections)."""
    for obj in depsgraph.objects:
        if is_splat_object(obj):
            yield obj


def item_for(obj_eval, depsgraph=None) -> RenderItem:
    # a sequence object's splats come from its frame files, not its PointCloud
    frame = sequence_runtime.sequence_frame(obj_eval, depsgraph) if depsgraph is not None else None
    splats = splats_from_pointcloud(obj_eval.data) if frame is None else frame.splats
    world = np.array(obj_eval.matrix_world, np.float64)
    key = (obj_eval.original.name, None if frame is None else frame.key)
    return RenderItem(splats=splats, world=world, key=key)


def collect_items(depsgraph) -> list[RenderItem]:
    return [item_for(obj, depsgraph) for obj in splat_objects(depsgraph)]
