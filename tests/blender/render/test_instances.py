"""Instances of splat objects through Splatline's engine (real bpy, F12's path): a collection
instance and Geometry Nodes' Instance on Points draw like real copies at their places, share
their source's upload, and sort with every other splat as one set."""
from __future__ import annotations

import numpy as np
import pytest

from testing.engine_scene import add_camera, add_splats, read_exr_parts, set_output, setup_render
from testing.instance_scene import (collection_instance, in_collection, instance_matrices, instance_on_points,
                                    merged_item, real_copies)
from testing.viewport_scene import psnr

W, H = 160, 96


def _render(bpy, scene, path):
    set_output(scene, "EXR", path)
    bpy.ops.render.render(write_still=True)
    return read_exr_parts(path.with_suffix(".exr"))["ViewLayer.Combined"]


def _guitar(bpy, testdata):
    from addon.blender.data.files import import_file

    obj = import_file(bpy.context, testdata / "guitar.ply", max_count=0)
    world = np.array(obj.matrix_world)
    from addon.blender.data.pointcloud import read_positions

    p = read_positions(obj.data).astype(np.float64) @ world[:3, :3].T + world[:3, 3]
    lo, hi = np.percentile(p, [2, 98], axis=0)
    return obj, (lo + hi) / 2, float(np.linalg.norm(hi - lo))


def test_collection_instance_of_guitar_renders_beside_it_as_a_real_copy(bpy_empty, testdata, tmp_path):
    from addon.blender.evaluate.items import collect_items

    bpy = bpy_empty
    guitar, centre, size = _guitar(bpy, testdata)
    collection = in_collection(bpy, guitar)
    add_camera(bpy, location=tuple(centre + (0.6 * size, -2.4 * size, 0.0)),
               target=tuple(centre + (0.6 * size, 0.0, 0.0)))
    scene = setup_render(bpy, W, H)
    alone = _render(bpy, scene, tmp_path / "alone")
    instance = collection_instance(bpy, collection, (1.2 * size, 0.0, 0.0))
    bpy.context.view_layer.update()
    items = collect_items(bpy.context.evaluated_depsgraph_get())
    assert [i.instance for i in items] == [(), ("Instance", 0)]
    assert items[1].splats is items[0].splats and items[1].key == items[0].key  # one upload
    got = _render(bpy, scene, tmp_path / "instanced")
    # every instance is in the frame: the instance beside the guitar adds at least most of
    # the guitar's coverage (measured: 640 pixels alone, 1403 with the instance)
    cover, cover_alone = (got[..., 3] > 0.5).sum(), (alone[..., 3] > 0.5).sum()
    assert cover_alone > 200 and cover - cover_alone > 0.8 * cover_alone
    matrices = instance_matrices(bpy, guitar.name_full)
    bpy.data.objects.remove(instance)
    real_copies(bpy, guitar, matrices)
    bpy.context.view_layer.update()
    want = _render(bpy, scene, tmp_path / "copies")
    assert_same_frame(got, want)


def assert_same_frame(got, want):
    """The same splats at the same places, drawn in another item order: the sort's depths
    are float32 relative to the first item's origin (gl/frame.py), so near-ties may swap
    and a few pixels move by rounding (measured: 0.1% of one channel at most, 0.7% of the
    values touched); the renderer's own bar against the reference is 60 dB."""
    assert psnr(got, want) >= 60.0 and np.abs(got - want).max() < 5e-3


@pytest.mark.parametrize("source", ["object", "collection"])
def test_instance_on_points_draws_four_overlapping_copies_sorted_as_one_object(bpy_empty, testdata, tmp_path,
                                                                              source):
    """test64.ply (degree 3) on 4 points closer than its size, scaled 0.8: the instances
    interleave in depth. The engine's frame equals one of 4 real copies, and matches the
    float64 reference of a single object holding all their splats."""
    from addon.blender.evaluate.items import collect_items
    from addon.blender.render.camera import camera_from_blender
    from addon.core import reference
    from addon.core.colorspace import premultiplied_srgb_to_linear as to_scene_linear
    from addon.core.formats import read

    bpy = bpy_empty
    capture = read(testdata / "test64.ply")
    obj = add_splats(bpy, "test64", capture)
    centre = capture.positions.astype(np.float64).mean(0)
    collection = in_collection(bpy, obj)
    target = collection if source == "collection" else obj
    points = np.array([(0.0, 0.0, 0.0), (0.08, 0.05, 0.0), (0.16, -0.04, 0.03), (0.05, 0.1, -0.05)])
    host = instance_on_points(bpy, points, target, scale=0.8)
    host.location = (0.5, 0.0, 0.0)
    # only the instances are drawn: their source's collection is left out of the view layer
    bpy.context.view_layer.layer_collection.children[collection.name].exclude = True
    # an instance holds the object's local splats, scaled, at its point
    seen = 0.8 * centre + points.mean(0) + host.location
    add_camera(bpy, location=tuple(seen + (0.1, -0.9, 0.3)), target=tuple(seen))
    scene = setup_render(bpy, W, H)
    bpy.context.view_layer.update()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    items = collect_items(depsgraph)
    assert len(items) == 4 and len({i.instance for i in items}) == 4
    assert all(i.splats is items[0].splats for i in items)
    got = _render(bpy, scene, tmp_path / "instanced")
    assert got[..., 3].max() > 0.5
    # the float64 reference of one object holding all the instances' splats
    camera = camera_from_blender(scene, scene.camera, depsgraph)
    merged = to_scene_linear(reference.render([merged_item(items)], camera).rgba)
    assert psnr(got, merged) >= 60.0
    # ...and not of the instances drawn one after the other (the order matters here)
    layered = sum_over([to_scene_linear(reference.render([i], camera).rgba) for i in items])
    assert psnr(layered, merged) < 50.0
    # Meshes: the holdout walks the instances' meshes; the mesh layer leaves out an object
    # whose nodes instance splats, which its engine would draw again (as points before 5.3)
    from addon.blender.render.mesh_layer import drawn_objects

    bpy.ops.mesh.primitive_cube_add(size=0.05, location=tuple(seen))
    cube = bpy.context.active_object
    assert cube in drawn_objects(scene) and host not in drawn_objects(scene)
    bpy.data.objects.remove(cube)
    matrices = instance_matrices(bpy, obj.name_full)
    host.modifiers[0].show_render = host.modifiers[0].show_viewport = False
    real_copies(bpy, obj, matrices)
    bpy.context.view_layer.update()
    want = _render(bpy, scene, tmp_path / "copies")
    assert_same_frame(got, want)


def sum_over(frames):
    """Premultiplied frames composited in list order, each over the ones before."""
    out = np.zeros_like(frames[0])
    for f in frames:
        out = f + (1.0 - f[..., 3:4]) * out
    return out


def test_mesh_layer_leaves_out_nodes_given_a_splat_object_as_input(bpy_empty, testdata):
    """The splat object reaches the nodes through the modifier's input, not a node's value."""
    from addon.blender.evaluate.items import collect_items
    from addon.blender.render.mesh_layer import drawn_objects
    from addon.core.formats import read

    bpy = bpy_empty
    obj = add_splats(bpy, "test64", read(testdata / "test64.ply"))
    host = instance_on_points(bpy, [(0, 0, 0), (1, 0, 0)], obj, as_input=True)
    scene = setup_render(bpy, W, H)
    bpy.context.view_layer.update()
    assert len(collect_items(bpy.context.evaluated_depsgraph_get())) == 3  # the object, 2 instances
    assert host not in drawn_objects(scene)


def test_vertex_instancing_places_a_child_on_each_vertex(bpy_empty, testdata):
    from addon.blender.evaluate.items import collect_items
    from addon.core.formats import read

    bpy = bpy_empty
    obj = add_splats(bpy, "test64", read(testdata / "test64.ply"))
    mesh = bpy.data.meshes.new("verts")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 2, 0)], [], [])
    parent = bpy.data.objects.new("Verts", mesh)
    bpy.context.scene.collection.objects.link(parent)
    parent.location = (0.0, 0.0, 5.0)
    parent.instance_type = "VERTS"
    obj.parent = parent
    bpy.context.view_layer.update()
    placed = {i.instance: tuple(np.round(i.world[:3, 3], 6)) for i in collect_items(bpy.context.evaluated_depsgraph_get())
              if i.instance}
    assert sorted(placed.values()) == [(0.0, 0.0, 5.0), (0.0, 2.0, 5.0), (1.0, 0.0, 5.0)]
    assert {path[0] for path in placed} == {"Verts"}


def test_command_line_renders_the_instances_as_f12_does(bpy_empty, testdata, tmp_path):
    """`python -m addon render` of a .blend with a collection instance: the frame F12 gives."""
    from addon.core.formats import read
    from testing.cli_runs import render_all

    bpy = bpy_empty
    capture = read(testdata / "test64.ply")
    obj = add_splats(bpy, "test64", capture)
    centre = capture.positions.astype(np.float64).mean(0)
    collection_instance(bpy, in_collection(bpy, obj), (0.3, 0.0, 0.0))
    add_camera(bpy, location=tuple(centre + (0.15, -1.2, 0.2)), target=tuple(centre + (0.15, 0.0, 0.0)))
    scene = setup_render(bpy, W, H)
    f12 = _render(bpy, scene, tmp_path / "f12")
    alone = (f12[:, : W // 2, 3] > 0.5).sum(), (f12[:, W // 2:, 3] > 0.5).sum()
    assert min(alone) > 20  # the object left of the middle, its instance right of it
    path = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    render_all([(path, "--out", tmp_path / "cli", "--format", "EXR", "--frames", "1")])
    cli = read_exr_parts(tmp_path / "cli" / "frame_0001.exr")["ViewLayer.Combined"]
    assert psnr(cli, f12) >= 60.0
