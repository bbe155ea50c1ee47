"""Evaluated splat objects -> RenderItems: the one place the viewport and the engine get data.

v1: reads the evaluated PointCloud (so modifiers apply) and the world matrix. The animation
layer adds look properties, the effect stack and sequences here.
"""
from __future__ import annotations

import numpy as np

from ..core.scene import RenderItem
from .pointcloud import is_splat_data, splats_from_pointcloud


def is_splat_object(obj) -> bool:
    return obj is not None and obj.type == "POINTCLOUD" and is_splat_data(obj.data)


def splat_objects(depsgraph):
    """Evaluated splat objects that the depsgraph considers visible (view layer, collections)."""
    for obj in depsgraph.objects:
        if is_splat_object(obj):
            yield obj


def item_for(obj_eval) -> RenderItem:
    splats = splats_from_pointcloud(obj_eval.data)
    world = np.array(obj_eval.matrix_world, np.float64)
    return RenderItem(splats=splats, world=world, key=(obj_eval.original.name, None))


def collect_items(depsgraph) -> list[RenderItem]:
    return [item_for(obj) for obj in splat_objects(depsgraph)]
