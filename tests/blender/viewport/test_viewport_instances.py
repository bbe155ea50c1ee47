"""Instances in the viewport: one source's data is packed and uploaded once, each instance
drawn through its own object row; all of them sorted as one set (real bpy, Blender's GPU)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from addon.core import reference
from addon.core.formats import read
from addon.core.scene import RenderItem
from addon.core.splats import ARRAYS
from testing.instance_scene import collection_instance, in_collection, merged_item
from testing.viewport_scene import camera_for, draw_offscreen, psnr

OFFSETS = ((0.0, 0.0, 0.0), (0.08, 0.05, 0.0), (0.16, -0.04, 0.03), (0.05, 0.1, -0.05))


def _placed(item, offset, scale, k):
    world = np.eye(4)
    world[:3, :3] *= scale
    world[:3, 3] = offset
    return replace(item, world=world, instance=() if k == 0 else ("Scatter", k))


def _scene(testdata):
    """test64.ply (degree 3) four times, overlapping: as instances of one item, and as four
    real copies (arrays of their own, keys of their own)."""
    capture = read(testdata / "test64.ply")
    item = RenderItem(capture, key=("test64", 1), base_key=("test64", 1), base_fields=frozenset(ARRAYS))
    instances = [_placed(item, o, 0.8, k) for k, o in enumerate(OFFSETS)]
    copies = []
    for k, inst in enumerate(instances):
        own = replace(capture, **{f: getattr(capture, f).copy() for f in ARRAYS})
        copies.append(replace(inst, splats=own, key=(f"copy{k}", 1), base_key=(f"copy{k}", 1), instance=()))
    centre = 0.8 * capture.positions.astype(np.float64).mean(0) + np.mean(OFFSETS, axis=0)
    return instances, copies, camera_for(centre)


def test_instances_draw_as_real_copies_from_one_upload(gpu_ready, testdata):
    instances, copies, camera = _scene(testdata)
    got, drew = draw_offscreen(instances, camera)
    want, drew_copies = draw_offscreen(copies, camera)
    merged = reference.render([merged_item(instances)], camera).rgba
    drew.close()
    drew_copies.close()
    assert got[..., 3].max() > 0.5
    assert psnr(got, want) >= 60.0 and np.abs(got - want).max() < 5e-3
    assert psnr(got, merged) >= 60.0  # sorted as one object of all the splats


def test_instances_add_no_data_texture_bytes(gpu_ready):
    """25 instances of 5000 splats hold the data textures of one object; 4 real copies hold
    four times as much."""
    from addon.blender.viewport.gpu_draw import texture_bytes
    from testing.viewport_scene import blob

    splats = blob(5_000, 2, seed=3, centre=(0, 0, 0), spread=0.3)
    item = RenderItem(splats, key=("blob", 1), base_key=("blob", 1), base_fields=frozenset(ARRAYS))
    camera = camera_for(np.zeros(3))
    sizes = {}
    for name, items in (("one", [item]),
                        ("instances", [_placed(item, (0.01 * k, 0, 0), 1.0, k) for k in range(25)]),
                        ("copies", [replace(item, splats=replace(splats, **{f: getattr(splats, f).copy()
                                                                            for f in ARRAYS}),
                                            key=("c", k), base_key=("c", k)) for k in range(4)])):
        _, drew = draw_offscreen(items, camera)
        sizes[name] = sum(texture_bytes(drew.gpu.textures[t]) for t in ("pos", "shape", "sh"))
        drew.close()
    assert sizes["instances"] == sizes["one"]
    assert sizes["copies"] > 3 * sizes["one"]  # four copies, each padded to whole rows


def test_scene_items_collects_a_collection_instance(gpu_ready, bpy_empty, testdata):
    from addon.blender.viewport.scene_items import SceneItems
    from testing.engine_scene import add_splats
    from testing.viewport_scene import overlay_drawn

    bpy = bpy_empty
    obj = overlay_drawn(add_splats(bpy, "test64", read(testdata / "test64.ply")))
    collection_instance(bpy, in_collection(bpy, obj), (0.3, 0.0, 0.0))
    bpy.context.view_layer.update()
    items, displays = SceneItems().collect(bpy.context)
    assert [i.instance for i in items] == [(), ("Instance", 0)] and len(displays) == 2
    assert items[1].splats is items[0].splats
    np.testing.assert_allclose(items[1].world[:3, 3] - items[0].world[:3, 3], (0.3, 0.0, 0.0), atol=1e-6)


def test_more_instances_than_a_texture_row_holds(gpu_ready):
    """2,000 instances (a Geometry Nodes scatter) need 22,000 texels of object table: more
    than the 16,384 a texture row may hold on the smallest GPU Blender supports. The table
    wraps into rows as the data textures do, and the grid draws as the reference draws it."""
    from addon.core.camera import look_at, simple_camera
    from testing.viewport_scene import blob

    splats = blob(12, 1, seed=5, centre=(0, 0, 0), spread=0.05)
    item = RenderItem(splats, key=("blob", 1))
    n, side = 2_000, 50
    grid = [_placed(item, ((k % side) * 0.2 - 4.9, (k // side) * 0.2 - 3.9, 0.0), 1.0, k) for k in range(n)]
    camera = simple_camera(96, 80, 50.0, look_at((0.0, -9.0, 9.0), (0.0, 0.0, 0.0)), near=0.1, far=100.0)
    got, drew = draw_offscreen(grid, camera)
    assert drew.gpu.object_count == n
    drew.close()
    want = reference.render([merged_item(grid)], camera).rgba
    covered = (want[..., 3] > 0.01).mean()
    print(f"{n} instances: {psnr(got, want):.1f} dB against the reference, {covered:.0%} of pixels covered")
    assert covered > 0.2 and psnr(got, want) >= 60.0


def test_lit_instances_are_each_lit_at_their_own_place(gpu_ready, testdata):
    """Look > Lighting on instances: the preprocess pass lights each instance through its own
    object row, sharing one upload, as the CPU lights each placed copy (core/lighting)."""
    from addon.blender.viewport import DrawSettings
    from addon.core.lighting.lights import Light
    from addon.core.lighting.shade import Lighting, lit_splats

    instances, _, camera = _scene(testdata)
    eye = tuple(np.linalg.inv(camera.world_to_camera)[:3, 3])
    centre = np.mean([i.world[:3, 3] for i in instances], axis=0)
    lighting = Lighting((Light("POINT", tuple(centre + (0.1, -0.2, 0.15)), (0.0, 0.0, -1.0), power=2.0),),
                        (0.1, 0.1, 0.1), eye)
    lit_here = [replace(i, lighting=1.0) for i in instances]
    got, drew = draw_offscreen(lit_here, camera, settings=DrawSettings(lighting=lighting))
    drew.close()
    on_cpu = [replace(i, splats=lit_splats(i.splats, i.world, lighting, 1.0), key=None) for i in instances]
    want = reference.render(on_cpu, camera).rgba
    unlit = reference.render(instances, camera).rgba
    print(f"lit instances: {psnr(got, want):.1f} dB against the reference, {psnr(unlit, want):.1f} unlit")
    assert psnr(unlit, want) < 40.0 and psnr(got, want) >= 60.0
