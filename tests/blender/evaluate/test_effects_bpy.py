"""The effect stack through bpy: copy-on-write, the base-splat cache, operators and keys."""
from __future__ import annotations

import numpy as np

from testing.animation_scene import add_object, grid_splats, items_at
from testing.viewport_scene import overlay_drawn


def _add(bpy, obj, kind):
    bpy.context.view_layer.objects.active = obj
    with bpy.context.temp_override(object=obj):
        assert bpy.ops.splatline.effect_add(type=kind) == {"FINISHED"}
    return obj.splatline.effects[-1]


def test_no_effects_costs_nothing_and_returns_the_cached_base(bpy_empty):
    bpy = bpy_empty
    add_object("capture", grid_splats())
    a = items_at(bpy, 1)[0]
    b = items_at(bpy, 7)[0]
    # the very same read-only arrays: no per-frame reading or copying
    assert a.splats.positions is b.splats.positions and a.splats.sh_rest is b.splats.sh_rest
    assert not a.splats.positions.flags.writeable
    assert a.key == b.key and a.positions_key == b.positions_key


def test_colour_and_opacity_effects_leave_positions_and_their_key(bpy_empty):
    bpy = bpy_empty
    obj = add_object("capture", grid_splats())
    base = items_at(bpy, 1)[0].splats
    grade = _add(bpy, obj, "GRADE")
    reveal = _add(bpy, obj, "REVEAL")
    grade.grade_field, reveal.reveal_shape, reveal.glow_strength = "NOISE", "NOISE", 1.0
    look = obj.splatline.look
    look.use_crop_sphere, look.crop_sphere_radius = True, 1.0
    for name, pairs in (("amount", ((1, 0.1), (20, 1.0))),):
        for frame, value in pairs:
            setattr(grade, name, value)
            grade.keyframe_insert(name, frame=frame)
    reveal.keyframe_insert("progress", frame=1)
    reveal.progress = 1.0
    reveal.keyframe_insert("progress", frame=20)
    first, later = items_at(bpy, 3)[0], items_at(bpy, 15)[0]
    # adding effects may re-read the base once (a stack edit); animating them never does
    assert first.splats.positions is later.splats.positions
    np.testing.assert_array_equal(first.splats.positions, base.positions)
    assert first.positions_key == later.positions_key
    assert first.key != later.key, "the colours changed, so the data key must"
    assert not np.array_equal(first.splats.sh_dc, later.splats.sh_dc)
    # a moving effect changes positions and their key
    _add(bpy, obj, "DISPLACE")
    moved = items_at(bpy, 15)[0]
    assert moved.positions_key != later.positions_key
    assert not np.array_equal(moved.splats.positions, base.positions)


def test_base_cache_rereads_on_geometry_edits_only(bpy_empty):
    bpy = bpy_empty
    # Plain points: on Blender 5.3+ a native splat object with a look gets a handoff
    # modifier (evaluate/native_handoff.py), and Blender reports the data of an object with
    # modifiers as new geometry on every property edit, so that one re-reads (docs/ARCHITECTURE.md).
    obj = overlay_drawn(add_object("capture", grid_splats()))
    first = items_at(bpy, 1)[0].splats
    obj.splatline.look.exposure = 1.0
    obj.location.x = 2.0
    again = items_at(bpy, 1)[0].splats
    assert again.positions is first.positions, "look or transform changes must not reread data"
    new = np.zeros(first.count * 3, np.float32)
    obj.data.attributes["position"].data.foreach_set("vector", new)
    obj.data.update_tag()
    edited = items_at(bpy, 1)[0].splats
    assert not edited.positions.any() and edited.positions is not first.positions


def test_morph_to_target_through_bpy_equals_target_in_source_space(bpy_empty):
    bpy = bpy_empty
    src = add_object("source", grid_splats(seed=1))
    tgt_splats = grid_splats(n_side=3, seed=2)
    tgt = add_object("target", tgt_splats, location=(1.0, 2.0, 3.0))
    src.location = (0.5, 0.0, 0.0)
    effect = _add(bpy, src, "MORPH")
    effect.target, effect.amount = tgt, 1.0
    items = {item.key[0]: item for item in items_at(bpy, 1)}
    morphed = items["source"].splats
    # at 1 the source shows exactly the target's splats, moved into the source's space
    np.testing.assert_allclose(morphed.positions, tgt_splats.positions + [0.5, 2.0, 3.0], atol=1e-6)
    np.testing.assert_array_equal(morphed.opacities, tgt_splats.opacities)
    np.testing.assert_array_equal(morphed.sh_dc, tgt_splats.sh_dc)
    effect.amount = 0.0
    src.update_tag(refresh={"TIME"})
    unmorphed = {i.key[0]: i for i in items_at(bpy, 1)}["source"].splats
    np.testing.assert_array_equal(unmorphed.positions, grid_splats(seed=1).positions)


def test_move_and_remove_keep_keyframes_with_their_effect(bpy_empty):
    bpy = bpy_empty
    obj = add_object("capture", grid_splats())
    first, second = _add(bpy, obj, "REVEAL"), _add(bpy, obj, "TWIST")
    first.keyframe_insert("progress", frame=1)
    second.keyframe_insert("twist", frame=1)
    from addon.blender.data.animation import channel_fcurves

    def paths():
        return sorted(c.data_path for c in channel_fcurves(obj))

    obj.splatline.active_effect = 0
    with bpy.context.temp_override(object=obj):
        assert bpy.ops.splatline.effect_move(direction="DOWN") == {"FINISHED"}
    assert [e.type for e in obj.splatline.effects] == ["TWIST", "REVEAL"]
    assert paths() == ["splatline.effects[0].twist", "splatline.effects[1].progress"]
    obj.splatline.active_effect = 0
    with bpy.context.temp_override(object=obj):
        assert bpy.ops.splatline.effect_remove() == {"FINISHED"}
        assert bpy.ops.splatline.effect_duplicate() == {"FINISHED"}
    assert paths() == ["splatline.effects[0].progress"]
    assert [e.type for e in obj.splatline.effects] == ["REVEAL", "REVEAL"]


def test_hidden_animated_morph_target_follows_its_keyframes(bpy_empty):
    """A hidden object is not evaluated by the depsgraph (its copy goes stale): its
    keyframed transform is evaluated at the frame instead, so every depsgraph agrees."""
    bpy = bpy_empty
    src = add_object("source", grid_splats(seed=1))
    tgt_splats = grid_splats(n_side=3, seed=2)
    tgt = add_object("target", tgt_splats)
    tgt.keyframe_insert("location", frame=1)
    tgt.location = (4.0, 0.0, 0.0)
    tgt.keyframe_insert("location", frame=11)
    for curve in tgt.animation_data.action.layers[0].strips[0].channelbag(tgt.animation_data.action_slot).fcurves:
        for key in curve.keyframe_points:
            key.interpolation = "LINEAR"
    tgt.hide_viewport = tgt.hide_render = True
    effect = _add(bpy, src, "MORPH")
    effect.target, effect.amount = tgt, 1.0
    items_at(bpy, 1)
    morphed = {i.key[0]: i for i in items_at(bpy, 6)}
    assert list(morphed) == ["source"]
    np.testing.assert_allclose(morphed["source"].splats.positions, tgt_splats.positions + [2.0, 0, 0],
                               atol=1e-5)


def test_base_cache_lets_deleted_data_go_and_shares_linked_duplicates(bpy_empty):
    from addon.blender.data import stored_splats

    bpy = bpy_empty
    doomed = add_object("doomed", grid_splats(seed=5))
    twin = doomed.copy()  # a linked duplicate: same PointCloud
    bpy.context.scene.collection.objects.link(twin)
    twin.location.x = 3.0
    items = {i.key[0]: i for i in items_at(bpy, 1)}
    assert items["doomed"].splats.positions is items[twin.name].splats.positions
    assert ("data", "doomed") in stored_splats.CACHE.entries
    data = doomed.data
    bpy.data.objects.remove(doomed)
    bpy.data.objects.remove(twin)
    bpy.data.pointclouds.remove(data)
    add_object("fresh", grid_splats(seed=6))
    items_at(bpy, 1)  # reading the new object prunes the deleted data
    assert ("data", "doomed") not in stored_splats.CACHE.entries
    assert ("data", "fresh") in stored_splats.CACHE.entries


def test_item_keys_change_exactly_when_the_splats_can(bpy_empty):
    bpy = bpy_empty
    obj = add_object("capture", grid_splats())
    twist = _add(bpy, obj, "TWIST")
    a, b = items_at(bpy, 3)[0], items_at(bpy, 9)[0]
    assert a.key == b.key and a.positions_key == b.positions_key  # no time dependence
    np.testing.assert_array_equal(a.splats.positions, b.splats.positions)
    twist.twist = 0.7
    obj.update_tag(refresh={"TIME"})
    c = items_at(bpy, 9)[0]
    assert c.key != b.key and c.positions_key != b.positions_key
    _add(bpy, obj, "DISPLACE")  # time-driven: every frame is new
    d, e = items_at(bpy, 3)[0], items_at(bpy, 9)[0]
    assert d.key != e.key and d.positions_key != e.positions_key
    assert not np.array_equal(d.splats.positions, e.splats.positions)


def test_added_gizmo_starts_where_the_default_field_is(bpy_empty):
    bpy = bpy_empty
    obj = add_object("capture", grid_splats())
    obj.location, obj.rotation_euler = (1.0, 2.0, 0.5), (0.3, 0.0, 0.8)
    effect = _add(bpy, obj, "REVEAL")
    effect.progress, effect.edge_width = 0.6, 0.3
    before = items_at(bpy, 1)[0].splats.opacities
    with bpy.context.temp_override(object=obj):
        assert bpy.ops.splatline.effect_add_gizmo() == {"FINISHED"}
    assert effect.gizmo is not None and effect.gizmo.type == "EMPTY"
    at_default = items_at(bpy, 1)[0].splats.opacities
    np.testing.assert_allclose(at_default, before, atol=1e-6)  # same frame, float64 round trip
    effect.gizmo.location.z += 0.5  # moving the gizmo moves the field
    moved = items_at(bpy, 1)[0].splats.opacities
    assert moved.sum() > before.sum()
