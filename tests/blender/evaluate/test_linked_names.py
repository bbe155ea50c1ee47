"""Objects are told apart by name_full: an object linked from a library beside a local
one of the same name keeps its own splats in the evaluator, the viewport, bake and export."""
from __future__ import annotations

import numpy as np
import pytest

from addon.blender.evaluate.items import collect_items
from addon.blender.data.pointcloud import new_pointcloud
from addon.core import formats
from testing.viewport_scene import blob, overlay_drawn


@pytest.fixture
def twins(bpy_empty, tmp_path):
    """A local 'cap' at z=0 and a 'cap' linked from lib.blend at z=5 (different data)."""
    bpy = bpy_empty
    linked_splats = blob(30, 0, seed=1, centre=(0, 0, 5), spread=0.1)
    # plain points, so Splatline's overlay draws them on Blender 5.3+ too
    obj = overlay_drawn(bpy.data.objects.new("cap", new_pointcloud("cap", linked_splats)))
    library = tmp_path / "lib.blend"
    bpy.data.libraries.write(str(library), {obj}, fake_user=True)
    bpy.data.objects.remove(obj)
    local_splats = blob(20, 0, seed=2, centre=(0, 0, 0), spread=0.1)
    local = overlay_drawn(bpy.data.objects.new("cap", new_pointcloud("cap", local_splats)))
    bpy.context.scene.collection.objects.link(local)
    with bpy.data.libraries.load(str(library), link=True) as (src, dst):
        dst.objects = ["cap"]
    linked = dst.objects[0]
    bpy.context.scene.collection.objects.link(linked)
    bpy.context.view_layer.update()
    assert linked.library is not None and linked.name == local.name
    assert linked.name_full != local.name_full
    return bpy, local, linked, local_splats, linked_splats


def _by_owner(items):
    return {item.key[0]: item for item in items}


def test_evaluator_keeps_linked_and_local_apart(twins):
    bpy, local, linked, local_splats, linked_splats = twins
    items = _by_owner(collect_items(bpy.context.evaluated_depsgraph_get()))
    assert set(items) == {local.name_full, linked.name_full}
    assert items[local.name_full].splats.count == 20
    np.testing.assert_allclose(items[linked.name_full].splats.positions, linked_splats.positions)


def test_viewport_keeps_linked_and_local_apart(twins):
    from addon.blender.viewport.scene_items import SceneItems

    bpy, local, linked, local_splats, linked_splats = twins
    cache = SceneItems()
    items, _ = cache.collect(bpy.context)
    assert sorted(i.splats.count for i in items) == [20, 30]
    assert set(cache.items) == {local.name_full, linked.name_full}
    local.location = (1.0, 0.0, 0.0)  # moves the local one only
    bpy.context.view_layer.update()
    items = _by_owner(cache.collect(bpy.context)[0])
    assert items[local.name_full].world[0, 3] == 1.0 and items[linked.name_full].world[0, 3] == 0.0


def test_bake_and_export_write_the_objects_own_splats(twins, tmp_path):
    from addon.blender.evaluate.bake import bake_frames, export_evaluated

    bpy, local, linked, local_splats, linked_splats = twins
    path = tmp_path / "linked.ply"
    export_evaluated(linked, bpy.context.evaluated_depsgraph_get(), str(path))
    np.testing.assert_allclose(formats.read(str(path)).positions, linked_splats.positions, atol=1e-6)
    frames = list(bake_frames(bpy.context, local, str(tmp_path / "bake"), 1, 1))
    assert formats.read(frames[0][1]).count == 20
