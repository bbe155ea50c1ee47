"""Viewport caching, invalidation and reload with real bpy (GPUOffScreen for drawing)."""
from __future__ import annotations

import threading
import time
from dataclasses import replace

import numpy as np
import pytest

from addon.core.scene import RenderItem
from addon.core.splats import ARRAYS
from testing.viewport_scene import blob, camera_for, draw_offscreen, overlay_drawn, psnr, two_objects


def _items():
    a = RenderItem(blob(300, 1, seed=1, centre=(0, 0, 0), spread=0.3), key=("a", 1))
    b = RenderItem(blob(200, 0, seed=2, centre=(0.2, 0, 0), spread=0.3), key=("b", 1))
    return [a, b]


def _orbit(camera, degrees):
    from addon.core.camera import look_at

    t = np.radians(degrees)
    eye = np.array([np.sin(t) * 1.5, -np.cos(t) * 1.5, 0.4])
    return replace(camera, world_to_camera=look_at(eye, (0, 0, 0)))


def test_still_camera_costs_no_sort_and_no_upload(gpu_ready):
    """Counts sorts and texture uploads (3 data textures: pos, shape, sh) per change."""
    from addon.blender.viewport import ViewportRenderer

    items, cam = _items(), _orbit(camera_for((0, 0, 0), 64, 48), 0)
    r = ViewportRenderer()
    draw_offscreen(items, cam, renderer=r)
    before = (r.stats.sorts, r.stats.uploads, r.stats.table_uploads)
    assert before == (1, 3, 1)
    draw_offscreen([replace(i) for i in items], cam, renderer=r)  # new RenderItems, same data
    assert (r.stats.sorts, r.stats.uploads, r.stats.table_uploads) == before
    draw_offscreen(items, _orbit(cam, 10), renderer=r)  # the view moved: sort, no data upload
    assert (r.stats.sorts, r.stats.uploads) == (2, 3)
    moved = [replace(items[0], world=np.eye(4) + np.eye(4, k=3) * 0.1), items[1]]
    draw_offscreen(moved, _orbit(cam, 10), renderer=r)  # transform only: matrix table, no data
    assert (r.stats.uploads, r.stats.table_uploads) == (3, 3)
    faded = replace(moved[0], splats=replace(items[0].splats, opacities=items[0].splats.opacities * 0.5))
    draw_offscreen([faded, items[1]], _orbit(cam, 10), renderer=r)  # opacity effect: pos only, no sort
    assert (r.stats.sorts, r.stats.uploads) == (3, 4)
    changed = [replace(faded, key=("a", 2)), items[1]]  # a new geometry version: every texture
    img, _ = draw_offscreen(changed, _orbit(cam, 10), renderer=r)
    assert r.stats.uploads == 7 and r.stats.sorts == 4
    fresh, _ = draw_offscreen(changed, _orbit(cam, 10))
    assert psnr(img, fresh) == float("inf")  # the cached path draws what a fresh renderer does


def test_background_sort_draws_the_last_order_then_catches_up(gpu_ready):
    from addon.blender.viewport import DrawSettings, ViewportRenderer

    items, cam = _items(), camera_for((0, 0, 0), 64, 48)
    r = ViewportRenderer(worker=True)
    worker = r.worker
    try:
        lazy = DrawSettings(sync_sort=False)
        draw_offscreen(items, _orbit(cam, 0), settings=lazy, renderer=r)  # no order yet: inline
        assert r.stats.sorts == 1
        draw_offscreen(items, _orbit(cam, 90), settings=lazy, renderer=r)  # queued, old order drawn
        deadline = time.time() + 20
        while r.sorting and time.time() < deadline:
            time.sleep(0.01)
        img, _ = draw_offscreen(items, _orbit(cam, 90), settings=lazy, renderer=r)  # picks it up
        assert r.stats.sorts == 2
        exact, _ = draw_offscreen(items, _orbit(cam, 90))
        assert psnr(img, exact) == float("inf")
    finally:
        r.close()
    assert not worker.alive and worker._thread not in threading.enumerate()


def _moved(items, frame):
    """Frame `frame` of a displace playing on the first object, as items.py hands it: new
    centres and key, the positions key new with them, the other arrays the base's own."""
    a = items[0]
    shifted = a.splats.positions + np.float32(0.05 * frame) * a.splats.positions[:, ::-1]
    kept = frozenset(ARRAYS) - {"positions"}
    return [replace(a, splats=replace(a.splats, positions=shifted), key=a.key + (frame,),
                    positions_key=a.key + ("moved", frame), base_key=a.key, base_fields=kept), items[1]]


def _settle(r):
    deadline = time.time() + 20
    while r.sorting and time.time() < deadline:
        time.sleep(0.01)


def test_moving_centres_keep_the_last_order_while_the_worker_sorts(gpu_ready, testdata):
    """An effect moving centres every frame (scrubbing a displace): the drawing thread
    draws the order it has, a permutation of the same splats, and takes each finished
    order even though the centres moved again since it was asked for; once they stop, the
    picture is the exact one. A new splat count is sorted inline: an old order of other
    splats is never drawn. The moving object is test64.ply, turned from its RDF frame."""
    from addon.blender.viewport import DrawSettings, ViewportRenderer

    items, centre = two_objects(testdata)
    items = [replace(i, key=(name, 0)) for name, i in zip("ab", items)]
    cam, lazy = camera_for(centre, 64, 48), DrawSettings(sync_sort=False)
    r = ViewportRenderer(worker=True)
    try:
        draw_offscreen(items, cam, settings=lazy, renderer=r)
        assert r.stats.sorts == 1
        draw_offscreen(_moved(items, 1), cam, settings=lazy, renderer=r)
        assert r.stats.sorts == 1 and r.stats.frame_sort == 0.0, "not sorted on the drawing thread"
        _settle(r)
        draw_offscreen(_moved(items, 2), cam, settings=lazy, renderer=r)  # takes frame 1's order
        assert r.stats.sorts == 2 and r.stats.frame_sort == 0.0
        _settle(r)
        img, _ = draw_offscreen(_moved(items, 2), cam, settings=lazy, renderer=r)  # frame 2's own
        assert r.stats.sorts == 3
        assert psnr(img, draw_offscreen(_moved(items, 2), cam)[0]) == float("inf")
        fewer = [items[0], replace(items[1], splats=items[1].splats.subset(np.arange(items[1].splats.count // 2)))]
        img, _ = draw_offscreen(fewer, cam, settings=lazy, renderer=r)
        assert r.stats.sorts == 4 and r.stats.frame_sort > 0.0, "another layout: sorted inline"
        assert psnr(img, draw_offscreen(fewer, cam)[0]) == float("inf")
    finally:
        r.close()


def _splat_object(bpy, name, splats):
    from addon.blender.data.pointcloud import new_pointcloud

    obj = bpy.data.objects.new(name, new_pointcloud(name, splats))
    bpy.context.scene.collection.objects.link(obj)
    return overlay_drawn(obj)


def _translate_modifier(bpy, obj):
    group = bpy.data.node_groups.new("shift", "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    gin, gout = group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")
    move = group.nodes.new("GeometryNodeTransform")
    group.links.new(gin.outputs[0], move.inputs["Geometry"])
    group.links.new(move.outputs["Geometry"], gout.inputs[0])
    move.inputs["Translation"].default_value = (1.0, 0.0, 0.0)
    obj.modifiers.new("shift", "NODES").node_group = group
    return move


def test_scene_items_follow_depsgraph_updates(bpy_empty):
    """The registered drawer's cache, fed by the real depsgraph_update_post handler."""
    from addon.blender import viewport

    bpy = bpy_empty
    splats = blob(50, 0, seed=3, centre=(0, 0, 0), spread=0.2)
    obj = _splat_object(bpy, "cap", splats)
    move = _translate_modifier(bpy, obj)
    cache = viewport.drawer().items
    bpy.context.view_layer.update()
    items, displays = cache.collect(bpy.context)
    assert len(items) == 1 and displays[0].key_bits == 16
    assert np.allclose(items[0].splats.positions, splats.positions + [1, 0, 0], atol=1e-6)
    first, version = items[0], cache.versions["cap"]

    obj.location = (0.0, 2.0, 0.0)  # transform only: same data, new matrix
    bpy.context.view_layer.update()
    items, _ = cache.collect(bpy.context)
    assert cache.versions["cap"] == version and items[0].splats is first.splats
    assert items[0].world[1, 3] == pytest.approx(2.0)

    move.inputs["Translation"].default_value = (0.0, 0.0, 3.0)  # the modifier changes the geometry
    bpy.context.view_layer.update()
    items, _ = cache.collect(bpy.context)
    assert cache.versions["cap"] > version and items[0].splats is not first.splats
    assert np.allclose(items[0].splats.positions, splats.positions + [0, 0, 3], atol=1e-6)

    obj.hide_set(True)
    assert cache.collect(bpy.context) == ([], [])


def test_display_settings_reach_the_drawing(bpy_empty):
    from addon.blender.viewport.scene_items import SceneItems

    bpy = bpy_empty
    obj = _splat_object(bpy, "cap", blob(10, 0, seed=4, centre=(0, 0, 0), spread=0.2))
    d = obj.splatline.display
    d.mode, d.splat_scale, d.max_sh_degree, d.sort_key_bits = "OPAQUE", 2.0, 1, "32"
    d.show_sh_only, d.frustum_culling, d.cull_dilation = True, False, 0.5
    bpy.context.view_layer.update()
    _, displays = SceneItems().collect(bpy.context)
    assert displays[0].mode == "OPAQUE" and displays[0].splat_scale == 2.0
    assert displays[0].max_sh_degree == 1 and displays[0].key_bits == 32
    assert displays[0].sh_only and not displays[0].cull and displays[0].dilation == 0.5


def test_register_unregister_three_times_leaves_nothing(_bpy_registered):
    import bpy

    from addon import register, unregister
    from addon.blender import viewport
    from addon.blender.viewport import handler

    drawers, handles = [], []
    unregister()  # the session fixture registered it
    try:
        for _ in range(3):
            register()
            drawers.append(viewport.drawer())
            handles.append(viewport.drawer()._handle)
            assert any(t.name == "splatline-sort" for t in threading.enumerate())
            unregister()
            assert viewport.drawer() is None
            assert not any(t.name.startswith("splatline") for t in threading.enumerate())
            assert handler._on_depsgraph not in bpy.app.handlers.depsgraph_update_post
            assert handler._on_frame not in bpy.app.handlers.frame_change_post
            assert not bpy.app.timers.is_registered(handler._redraw_timer)
            assert not hasattr(bpy.types, "SPLATLINE_PT_viewport_stats")
    finally:
        register()
    for handle in handles:  # every draw handler was removed: removing it again is refused
        with pytest.raises(ValueError):
            bpy.types.SpaceView3D.draw_handler_remove(handle, "WINDOW")
    assert len({id(d) for d in drawers}) == 3


def test_viewport_draws_after_an_f12_render(bpy_empty, gpu_ready, tmp_path):
    """The offscreen renderer's own GL context must leave Blender's GPU context usable."""
    from addon.blender.evaluate.items import collect_items
    from addon.core import reference
    from addon.core.scene import RenderOptions
    from testing.engine_scene import add_camera, add_splats, setup_render

    bpy = bpy_empty
    add_splats(bpy, "cap", blob(80, 1, seed=5, centre=(0, 0, 0), spread=0.4))
    add_camera(bpy, location=(0.0, -4.0, 0.5))
    setup_render(bpy, 32, 24)
    bpy.context.scene.render.filepath = str(tmp_path / "f12.png")
    bpy.ops.render.render(write_still=True)
    items = collect_items(bpy.context.evaluated_depsgraph_get())
    cam = camera_for((0, 0, 0), 64, 48)
    rgba, _ = draw_offscreen(items, cam)
    assert psnr(rgba, reference.render(items, cam, RenderOptions()).rgba) >= 60.0


def test_selection_does_not_reread_but_a_look_edit_does(bpy_empty):
    from addon.blender import viewport

    bpy = bpy_empty
    obj = _splat_object(bpy, "cap", blob(20, 0, seed=6, centre=(0, 0, 0), spread=0.2))
    cache = viewport.drawer().items
    bpy.context.view_layer.update()
    cache.collect(bpy.context)
    version = cache.versions["cap"]
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    obj.splatline.display.splat_scale = 3.0  # viewport-only: read each draw, no re-read
    bpy.context.view_layer.update()
    assert cache.versions["cap"] == version
    look = obj.splatline.look
    name = next(p.identifier for p in look.bl_rna.properties if p.type == "FLOAT" and not p.is_array)
    setattr(look, name, getattr(look, name) + 0.25)
    bpy.context.view_layer.update()
    assert cache.versions["cap"] > version


def test_hidden_objects_and_collections_are_not_drawn(bpy_empty):
    from addon.blender.evaluate import items as evaluate
    from addon.blender.viewport.scene_items import SceneItems

    bpy = bpy_empty
    a = _splat_object(bpy, "a", blob(10, 0, seed=8, centre=(0, 0, 0), spread=0.2))
    coll = bpy.data.collections.new("inner")
    bpy.context.scene.collection.children.link(coll)
    b = bpy.data.objects.new("b", a.data.copy())
    coll.objects.link(b)
    cache = SceneItems()

    def names():  # the objects collect() returned items for (it forgets the others)
        bpy.context.view_layer.update()
        items, _ = cache.collect(bpy.context)
        assert len(items) == len(cache.items)
        return sorted(cache.items)

    assert names() == ["a", "b"]
    layer = bpy.context.view_layer.layer_collection.children["inner"]
    layer.hide_viewport = True  # the eye icon of the collection
    assert names() == ["a"]
    layer.hide_viewport = False
    layer.exclude = True
    assert names() == ["a"]
    layer.exclude = False
    coll.hide_viewport = True  # the monitor icon (disabled in viewports)
    assert names() == ["a"]
    coll.hide_viewport = False
    a.hide_viewport = True
    assert names() == ["b"]
    a.hide_viewport = False
    b.splatline.look.visible = False  # Look > Show off: not packed, uploaded or sorted
    evaluated = []
    real = evaluate.item_for
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(evaluate, "item_for", lambda o, d=None, defer=None: evaluated.append(o.name) or real(o, d, defer))
        assert names() == ["a"]
        cache.invalidate()
        evaluated.clear()
        assert names() == ["a"] and evaluated == ["a"]


def _far_camera(width=64, height=48, distance=6.0):
    """Every splat of a [-1, 1]^3 grid well inside the view: the frustum test drops none."""
    from addon.core.camera import look_at, simple_camera

    eye = np.array([0.3, -distance, 0.8])
    return simple_camera(width, height, 45.0, look_at(eye, (0, 0, 0)), near=0.05, far=50.0)


def test_colour_and_opacity_animation_keeps_the_sort(bpy_empty, gpu_ready):
    """An animated Reveal (opacity, scale, glow) and Grade change every frame's data key,
    but not the centres: the viewport re-uploads data and keeps its order. Displace moves
    the centres, and re-sorts."""
    from addon.blender.viewport import ViewportRenderer
    from testing.animation_scene import add_object, grid_splats, items_at

    bpy = bpy_empty
    obj = add_object("capture", grid_splats(n_side=6))
    bpy.context.view_layer.objects.active = obj
    with bpy.context.temp_override(object=obj):
        for kind in ("REVEAL", "GRADE"):
            bpy.ops.splatline.effect_add(type=kind)
    reveal = obj.splatline.effects[0]
    reveal.glow_strength = 1.0
    for frame, progress in ((1, 0.0), (20, 1.0)):
        reveal.progress = progress
        reveal.keyframe_insert("progress", frame=frame)
    cam, r = _far_camera(), ViewportRenderer()
    draw_offscreen(items_at(bpy, 5), cam, renderer=r)
    sorts, uploads = r.stats.sorts, r.stats.uploads
    later = items_at(bpy, 12)
    img, _ = draw_offscreen(later, cam, renderer=r)
    assert r.stats.uploads > uploads, "the colours and opacities changed: data goes up"
    assert r.stats.sorts == sorts, "no centre moved: the order stays"
    assert psnr(img, draw_offscreen(later, cam)[0]) == float("inf")  # what a fresh renderer draws

    with bpy.context.temp_override(object=obj):
        bpy.ops.splatline.effect_add(type="DISPLACE")
    img, _ = draw_offscreen(items_at(bpy, 12), cam, renderer=r)
    assert r.stats.sorts == sorts + 1
    assert psnr(img, draw_offscreen(items_at(bpy, 12), cam)[0]) == float("inf")


def test_growing_splats_resort_only_when_the_order_culled_by_radius(gpu_ready):
    """The kept order is valid for new radii unless the frustum test dropped splats: a
    splat that grows may then reach the view."""
    from addon.blender.viewport import ViewportRenderer
    from testing.animation_scene import grid_splats

    splats = grid_splats(n_side=6)
    base = RenderItem(splats, key=("a", 0), positions_key=("a", 0))
    grown = RenderItem(replace(splats, scales=splats.scales * 3.0), key=("a", 1), positions_key=("a", 0))
    near = replace(_orbit(camera_for((0, 0, 0), 64, 48), 20), near=0.05)  # 1.5 away: edges culled
    for cam, resorts in ((_far_camera(), False), (near, True)):
        r = ViewportRenderer()
        draw_offscreen([base], cam, renderer=r)
        assert r.state.sorted_radius_dependent == resorts
        img, _ = draw_offscreen([grown], cam, renderer=r)
        assert r.stats.sorts == 1 + resorts
        assert psnr(img, draw_offscreen([grown], cam)[0]) == float("inf")


def test_moving_what_an_effect_reads_re_evaluates_it(bpy_empty):
    """A Reveal's gizmo, a morph target and the object's own transform feed its effects:
    moving any of them by hand (no frame change) must show in the viewport's items, while
    a splat object without effects still reuses its data on a transform-only move."""
    from addon.blender import viewport
    from addon.blender.evaluate.items import item_for
    from addon.blender.viewport.effect_rows import on_gpu
    from testing.animation_scene import add_object, grid_splats

    bpy = bpy_empty
    obj = overlay_drawn(add_object("cap", grid_splats(n_side=5)))
    target = overlay_drawn(add_object("goal", grid_splats(n_side=5, seed=9), location=(0.0, 0.0, 2.0)))
    plain = overlay_drawn(add_object("plain", grid_splats(n_side=3, seed=4)))
    bpy.context.view_layer.objects.active = obj
    with bpy.context.temp_override(object=obj):
        bpy.ops.splatline.effect_add(type="REVEAL")
        bpy.ops.splatline.effect_add_gizmo()
        bpy.ops.splatline.effect_add(type="MORPH")
    reveal, morph = obj.splatline.effects
    reveal.progress, morph.target, morph.amount = 0.0, target, 0.5
    cache = viewport.drawer().items

    def current():
        bpy.context.view_layer.update()
        items, _ = cache.collect(bpy.context)
        return {i.key[0]: i for i in items}

    def fresh():  # as the viewport evaluates: the morph left to the preprocess pass
        depsgraph = bpy.context.evaluated_depsgraph_get()
        return item_for(bpy.data.objects["cap"].evaluated_get(depsgraph), depsgraph, defer=on_gpu)

    before = current()
    for move in (lambda: setattr(reveal.gizmo, "location", (0.0, 0.0, -0.3)),
                 lambda: setattr(target, "location", (1.0, 0.0, 2.0)),
                 lambda: setattr(obj, "rotation_euler", (0.0, 0.4, 0.0))):
        move()
        now = current()
        assert not np.array_equal(now["cap"].splats.positions, before["cap"].splats.positions) or \
            not np.array_equal(now["cap"].splats.opacities, before["cap"].splats.opacities)
        want = fresh()
        assert [type(d.params).__name__ for d in want.deferred] == ["Morph"]
        np.testing.assert_array_equal(now["cap"].splats.positions, want.splats.positions)
        np.testing.assert_array_equal(now["cap"].splats.opacities, want.splats.opacities)
        np.testing.assert_array_equal(now["cap"].deferred[0].params.target.positions,
                                      want.deferred[0].params.target.positions)
        assert now["plain"].splats is before["plain"].splats  # nothing it reads moved
        before = now
    plain.location = (0.0, 3.0, 0.0)
    assert current()["plain"].splats is before["plain"].splats  # transform only: no re-read
    version = cache.versions["cap"]
    obj.splatline.display.splat_scale = 2.0  # viewport-only, on an object with effects
    assert current()["cap"].splats is before["cap"].splats and cache.versions["cap"] == version
