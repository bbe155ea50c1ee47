"""Real captures in Blender under the transforms users give them, and their evaluated
splats: shared by the effect and preset tests on guitar and test64."""
from __future__ import annotations

import math

import numpy as np

from addon.blender.data.files import import_file
from addon.blender.evaluate.items import collect_items

TRANSFORMS = ("imported", "turned_scaled", "parented")


def place(bpy, testdata, name, transform="imported", suffix=""):
    """Import `name` (its axes as a rotation on the object), then turn and scale it, or
    parent it to a moved, turned, 0.4-scaled Empty."""
    obj = import_file(bpy.context, str(testdata / name))
    obj.name = obj.name + suffix
    if transform == "turned_scaled":
        obj.rotation_euler.rotate_axis("X", math.radians(50))
        obj.rotation_euler.rotate_axis("Z", math.radians(30))
        obj.scale = (2.5, 2.5, 2.5)
        obj.location = (1.0, -2.0, 0.5)
    elif transform == "parented":
        parent = bpy.data.objects.new("rig" + suffix, None)
        bpy.context.scene.collection.objects.link(parent)
        parent.location = (3.0, 1.0, -1.0)
        parent.rotation_euler = (math.radians(70), math.radians(-20), math.radians(40))
        parent.scale = (0.4, 0.4, 0.4)
        obj.parent = parent
    bpy.context.view_layer.update()
    return obj


def item_at(bpy, name_full, frame=1):
    """The RenderItem the viewport and F12 get for the object at `frame`."""
    bpy.context.scene.frame_set(int(frame))
    items = collect_items(bpy.context.evaluated_depsgraph_get())
    return next(i for i in items if i.key[0] == name_full)


def own_item(bpy, obj, frame):
    """The object's splats with its effects off: each splat's own values."""
    for effect in obj.splatline.effects:
        effect.enabled = False
    item = item_at(bpy, obj.name_full, frame)
    for effect in obj.splatline.effects:
        effect.enabled = True
    return item


def world_positions(item):
    return item.splats.positions.astype(np.float64) @ item.world[:3, :3].T + item.world[:3, 3]


def frame_and_stack(bpy, obj, world):
    """(the object's source frame, its effect stack, the time in seconds) at the current
    frame, as evaluate/items.item_for builds them: for tests that run the stack themselves."""
    from addon.blender.evaluate import effect_params, items

    depsgraph = bpy.context.evaluated_depsgraph_get()
    obj_eval = obj.evaluated_get(depsgraph)
    frame = items.source_frame(obj_eval, depsgraph)
    time, fps = items.scene_time(depsgraph)
    stack = effect_params.stack(obj_eval, depsgraph, world, time, fps, frame.splats,
                                frame.key, items.base_splats)
    return frame, stack, time
