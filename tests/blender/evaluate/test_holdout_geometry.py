"""What hides splats: evaluate/holdout_geometry.py reads the surfaces of the
depsgraph the engine renders into world-space triangles.

The render's own depsgraph decides visibility (hide_render, excluded collections), so
every case here is read inside a real render: the engine's holdout_for is wrapped to keep
what it returned. The scene of holdout_scenes is read back exactly (same depth per pixel).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from testing.engine_scene import add_camera, setup_render

CUBE_TRIS = 12


@pytest.fixture
def rendered_holdout(bpy_empty, monkeypatch):
    """render() -> the triangles ((T, 3, 3) float64) the engine's last frame held out."""
    from addon.blender.render import engine

    seen = []

    def spy(depsgraph):
        holdout = original(depsgraph)
        seen.append(np.zeros((0, 3, 3)) if holdout is None else holdout.triangles)
        return holdout

    original = engine.holdout_for
    monkeypatch.setattr(engine, "holdout_for", spy)

    def render():
        bpy = bpy_empty
        scene = bpy.context.scene
        if scene.camera is None:
            add_camera(bpy)
        setup_render(bpy, 8, 8, renderer="REFERENCE")
        scene.splatline.render.meshes = "HOLDOUT"  # the holdout alone: no mesh layer
        seen.clear()
        bpy.ops.render.render()
        assert seen, "the engine asked for the holdout"
        return seen[-1]

    return render


def _cube(bpy, location=(0.0, 0.0, 0.0), size=1.0, collection=None):
    bpy.ops.mesh.primitive_cube_add(size=size, location=location)
    obj = bpy.context.object
    if collection is not None:
        for c in list(obj.users_collection):
            c.objects.unlink(obj)
        collection.objects.link(obj)
    return obj


def test_every_surface_type_and_modifiers(bpy_empty, rendered_holdout):
    bpy = bpy_empty
    cube = _cube(bpy, (3.0, 0.0, 0.0))
    array = cube.modifiers.new("Array", "ARRAY")
    array.count = 3
    text = bpy.data.objects.new("Text", bpy.data.curves.new("Text", "FONT"))
    text.data.body = "A"
    bpy.context.scene.collection.objects.link(text)
    bpy.ops.curve.primitive_bezier_circle_add(location=(0.0, 3.0, 0.0))
    bpy.context.object.data.bevel_depth = 0.1
    bpy.ops.surface.primitive_nurbs_surface_sphere_add(location=(0.0, -3.0, 0.0))
    bpy.ops.object.metaball_add(type="BALL", location=(0.0, 0.0, 3.0))
    tris = rendered_holdout()
    xs = tris[..., 0].mean(1)
    cubes = np.sum((xs > 2.0) & (np.abs(tris[..., 1].mean(1)) < 1.0))
    assert cubes == 3 * CUBE_TRIS, "the Array modifier's three cubes"
    assert np.isclose(tris[..., 0].max(), 3.0 + 2 * 1.0 + 0.5), "the last copy 2 m on"
    for name, where in (("curve", (0, 3, 0)), ("surface", (0, -3, 0)), ("metaball", (0, 0, 3)),
                        ("text", (0, 0, 0))):
        near = np.linalg.norm(tris.mean(1) - where, axis=1) < 1.2
        assert near.sum() > 4, f"the {name} hides splats"


def test_what_does_not_hide_splats(bpy_empty, testdata, rendered_holdout):
    """Hidden from the render, excluded, indirect only, camera-invisible objects, and
    everything that is not a surface: splats, cameras, lights, empties."""
    from testing.engine_scene import add_splats, flat_splats

    bpy = bpy_empty
    scene = bpy.context.scene
    _cube(bpy, (0.0, 0.0, 0.0))  # the one that counts
    _cube(bpy, (2.0, 0.0, 0.0)).hide_render = True
    _cube(bpy, (4.0, 0.0, 0.0)).visible_camera = False
    for name, flag in (("excluded", "exclude"), ("indirect", "indirect_only"),
                       ("off", None)):
        coll = bpy.data.collections.new(name)
        scene.collection.children.link(coll)
        _cube(bpy, (6.0, 0.0, 0.0), collection=coll)
        if flag is None:
            coll.hide_render = True
        else:
            setattr(bpy.context.view_layer.layer_collection.children[name], flag, True)
    add_splats(bpy, "splats", flat_splats([[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]]))
    bpy.ops.object.light_add(type="POINT", location=(0.0, 0.0, 5.0))
    bpy.ops.object.empty_add(location=(0.0, 1.0, 0.0))
    tris = rendered_holdout()
    assert tris.shape == (CUBE_TRIS, 3, 3)
    assert np.allclose(tris.reshape(-1, 3).mean(0), 0.0, atol=1e-6)


def test_holdout_objects_still_hide_splats(bpy_empty, rendered_holdout):
    """Object > Visibility > Holdout: Blender renders a hole there; it is still opaque."""
    bpy = bpy_empty
    _cube(bpy).is_holdout = True
    assert rendered_holdout().shape == (CUBE_TRIS, 3, 3)


def test_instances_at_their_matrices(bpy_empty, rendered_holdout):
    """A collection instanced twice (collection excluded from the view layer): two cubes,
    placed and rotated by the instancing empties; and a rotated, scaled object."""
    bpy = bpy_empty
    scene = bpy.context.scene
    coll = bpy.data.collections.new("prop")
    scene.collection.children.link(coll)
    _cube(bpy, (0.0, 0.0, 0.5), size=1.0, collection=coll)
    bpy.context.view_layer.layer_collection.children["prop"].exclude = True
    for x, angle in ((10.0, 0.0), (-10.0, math.pi / 4)):
        empty = bpy.data.objects.new(f"inst{x}", None)
        empty.instance_type = "COLLECTION"
        empty.instance_collection = coll
        empty.location = (x, 0.0, 0.0)
        empty.rotation_euler = (0.0, 0.0, angle)
        scene.collection.objects.link(empty)
    tris = rendered_holdout()
    assert tris.shape == (2 * CUBE_TRIS, 3, 3)
    right = tris[tris[..., 0].mean(1) > 0].reshape(-1, 3)
    left = tris[tris[..., 0].mean(1) < 0].reshape(-1, 3)
    np.testing.assert_allclose(right.min(0), (9.5, -0.5, 0.0), atol=1e-6)
    np.testing.assert_allclose(left.max(0)[:2], (-10.0 + math.sqrt(0.5), math.sqrt(0.5)), atol=1e-6)


def test_scene_surfaces_read_back_exactly(bpy_empty, testdata):
    """holdout_scenes.guitar_scene from primitives: the depth of the nearest surface at
    every pixel equals the scene's own triangles' (float32 vertices, Blender's diagonals)."""
    from addon.blender.evaluate.holdout_geometry import holdout_triangles
    from addon.core.holdout import Holdout, holdout_depth
    from testing.mesh_layer_scene import build

    bpy = bpy_empty
    hs, _objects, _ = build(bpy, testdata, 96, 64, count=1000)
    read = holdout_triangles(bpy.context.evaluated_depsgraph_get())
    assert read.shape == (2 * CUBE_TRIS + 2, 3, 3)
    want = holdout_depth(hs.holdout, hs.camera)
    got = holdout_depth(Holdout(read), hs.camera)
    assert (np.isfinite(want) != np.isfinite(got)).sum() <= 2, "the same pixels, edges aside"
    both = np.isfinite(want) & np.isfinite(got)
    np.testing.assert_allclose(got[both], want[both], rtol=1e-5)
