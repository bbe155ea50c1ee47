"""Helpers for the animation tests: small splat objects and a bitwise snapshot of items."""
from __future__ import annotations

import numpy as np

from addon.core.splats import AXES_RFU, SplatSet

ARRAYS = ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")


def grid_splats(n_side=4, degree=1, seed=0) -> SplatSet:
    """n_side^3 splats on a jittered grid in [-1, 1]^3, with varied colours and SH."""
    rng = np.random.default_rng(seed)
    axis = np.linspace(-1.0, 1.0, n_side)
    pos = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), -1).reshape(-1, 3)
    s = SplatSet.allocate(len(pos), degree, AXES_RFU)
    s.positions[:] = pos + rng.normal(0, 0.05, pos.shape)
    s.scales[:] = rng.uniform(0.05, 0.15, (len(pos), 3))
    q = rng.normal(size=(len(pos), 4))
    s.rotations[:] = q / np.linalg.norm(q, axis=1, keepdims=True)
    s.opacities[:] = rng.uniform(0.3, 0.9, len(pos))
    s.sh_dc[:] = rng.normal(0, 0.5, (len(pos), 3))
    s.sh_rest[:] = rng.normal(0, 0.1, s.sh_rest.shape)
    return s.check()


def add_object(name, splats, location=(0.0, 0.0, 0.0)):
    from addon.blender.data.pointcloud import new_pointcloud_object

    obj = new_pointcloud_object(name, splats)
    obj.location = location
    return obj


def snapshot(item) -> tuple:
    """Everything a renderer reads from an item, as bytes (bitwise comparison)."""
    parts = [getattr(item.splats, name).tobytes() for name in ARRAYS]
    parts += [np.asarray(item.world, np.float64).tobytes(),
              np.asarray(item.color_matrix, np.float64).tobytes(),
              repr((item.splat_scale, item.opacity_scale, item.sh_degree))]
    return tuple(parts)


def items_at(bpy, frame):
    from addon.blender.evaluate.items import collect_items

    bpy.context.scene.frame_set(frame)
    items = collect_items(bpy.context.evaluated_depsgraph_get())
    return sorted(items, key=lambda item: item.key[0])
