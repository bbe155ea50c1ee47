"""Keyframes on every look property and effect parameter change the evaluated splats where
they should and nowhere else (real bpy, collect_items).

Method, for each property P with keyframes A at frame 10 and B at frame 20: the animated
item at frames 5, 10, 15, 20, 25 is compared bitwise with the item of the same scene
without animation and P set statically to the value Blender's curve has at that frame
(A before 10, B after 20). So effects that depend on time are accounted for, and any
leak (a value carried between frames, the wrong property read) shows as a mismatch.
Then A and B must give different items (the property matters) and, for a float, frame 15
must differ from both (it interpolates).
"""
from __future__ import annotations

import pytest

from testing.animation_scene import add_object, grid_splats, items_at, snapshot

# (base settings, [(property, A, B), ...]): each group starts from its own base so that
# every property visibly matters on the 4x4x4 grid in [-1, 1]^3.
LOOK = [
    ({}, [("opacity", 1.0, 0.4), ("size", 1.0, 2.0), ("tint", (1.0, 1.0, 1.0), (0.2, 0.5, 1.0)),
          ("exposure", 0.0, 1.5), ("saturation", 1.0, 0.2), ("hue", 0.0, 1.0),
          ("max_sh_degree", 1, 0)]),
    ({"use_crop_box": True, "crop_box_size": (1.5, 1.5, 1.5)},
     [("use_crop_box", False, True), ("crop_box_center", (0, 0, 0), (0.5, 0.2, 0.0)),
      ("crop_box_size", (1.5, 1.5, 1.5), (1.0, 2.0, 1.0)), ("crop_box_softness", 0.0, 1.2),
      ("crop_box_invert", False, True)]),
    ({"use_crop_sphere": True, "crop_sphere_radius": 1.2},
     [("use_crop_sphere", False, True), ("crop_sphere_center", (0, 0, 0), (0.3, 0, 0)),
      ("crop_sphere_radius", 1.2, 0.3), ("crop_sphere_softness", 0.0, 1.2),
      ("crop_sphere_invert", False, True)]),
]

# (effect type, base settings, [(property, A, B), ...])
EFFECTS = [
    ("REVEAL", {"progress": 0.0, "edge_width": 0.5, "glow_strength": 1.0},
     [("progress", -0.5, 0.5), ("edge_width", 0.2, 1.0), ("shrink", 0.0, 1.0),
      ("glow_strength", 0.0, 2.0), ("glow_color", (1, 0, 0), (0, 0, 1)), ("amount", 0.2, 1.0),
      ("invert", False, True), ("enabled", True, False), ("reveal_shape", "PLANE", "SPHERE")]),
    ("REVEAL", {"reveal_shape": "NOISE", "progress": 0.5, "edge_width": 0.2},
     [("frequency", 1.0, 3.0), ("seed", 0, 5)]),
    ("DISPLACE", {"amplitude": 0.2},
     [("amplitude", 0.1, 0.4), ("frequency", 1.0, 2.5), ("speed", 0.0, 2.0), ("seed", 0, 3),
      ("amount", 0.3, 1.0)]),
    ("EXPLODE", {"start_frame": 1.0, "spin": 1.0, "fade": 0.5, "gravity": 1.0},
     [("strength", 0.5, 2.0), ("spread", 0.0, 1.0), ("spin", 0.0, 3.0), ("gravity", 0.0, 3.0),
      ("start_frame", 1.0, 4.0), ("fade", 0.0, 2.0), ("seed", 0, 7), ("amount", 0.5, 1.0),
      ("explode_mode", "CENTER", "DIRECTION")]),
    ("TWIST", {"swirl": 1.0},
     [("twist", 0.0, 1.0), ("swirl", 0.0, 2.0), ("swirl_radius", 0.5, 2.0), ("amount", 0.5, 1.0)]),
    ("GRADE", {"use_color_mid": True, "range_low": -1.0, "range_high": 1.0},
     [("color_a", (0, 0, 1), (1, 1, 0)), ("color_b", (1, 0, 0), (0, 1, 0)),
      ("color_mid", (1, 1, 1), (0, 0, 0)), ("mid_position", 0.3, 0.7), ("range_low", -1.0, 0.0),
      ("range_high", 1.0, 2.0), ("amount", 0.3, 1.0), ("use_color_mid", True, False),
      ("grade_field", "HEIGHT", "DISTANCE"), ("grade_mode", "MIX", "ADD")]),
    ("GRADE", {"grade_field": "NOISE"}, [("frequency", 1.0, 2.0), ("seed", 0, 4)]),
]

FRAMES = (5, 10, 15, 20, 25)


def _set(owner, name, value):
    setattr(owner, name, value)
    owner.id_data.update_tag(refresh={"TIME"})


def _clear_animation(obj):
    obj.animation_data_clear()


def _check_property(bpy, obj, owner, name, a, b):
    """Animated A@10 -> B@20 against static evaluations at every frame in FRAMES."""
    _clear_animation(obj)
    _set(owner, name, a)
    owner.keyframe_insert(name, frame=10)
    _set(owner, name, b)
    owner.keyframe_insert(name, frame=20)
    animated, curve_values = {}, {}
    for f in FRAMES:
        animated[f] = snapshot(items_at(bpy, f)[0])
        value = getattr(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).path_resolve(
            owner.path_from_id()), name)
        curve_values[f] = tuple(value) if hasattr(value, "__len__") and not isinstance(value, str) else value
    _clear_animation(obj)
    for f in FRAMES:
        _set(owner, name, curve_values[f])
        static = snapshot(items_at(bpy, f)[0])
        assert animated[f] == static, f"{name}: animated frame {f} differs from static value {curve_values[f]}"
    assert curve_values[5] == curve_values[10] and curve_values[20] == curve_values[25]
    _set(owner, name, a)
    at_a = snapshot(items_at(bpy, 20)[0])
    assert at_a != animated[20], f"{name}: values {a} and {b} give the same splats"
    if isinstance(a, float):
        assert animated[15] != animated[10] and animated[15] != animated[20], name
    _set(owner, name, a)


@pytest.mark.parametrize("base,props", LOOK, ids=["colour", "box", "sphere"])
def test_every_look_property_is_animatable(bpy_empty, base, props):
    bpy = bpy_empty
    obj = add_object("capture", grid_splats())
    look = obj.splatline.look
    for name, a, b in props:
        for base_name, value in base.items():
            _set(look, base_name, value)
        _check_property(bpy, obj, look, name, a, b)


@pytest.mark.parametrize("kind,base,props", EFFECTS, ids=[f"{e[0]}-{i}" for i, e in enumerate(EFFECTS)])
def test_every_effect_parameter_is_animatable(bpy_empty, kind, base, props):
    bpy = bpy_empty
    obj = add_object("capture", grid_splats())
    bpy.context.view_layer.objects.active = obj
    with bpy.context.temp_override(object=obj):
        bpy.ops.splatline.effect_add(type=kind)
    effect = obj.splatline.effects[0]
    for name, a, b in props:
        for base_name, value in base.items():
            _set(effect, base_name, value)
        _check_property(bpy, obj, effect, name, a, b)


def test_morph_amount_animates_and_ends_match_source_and_target(bpy_empty):
    bpy = bpy_empty
    source = add_object("source", grid_splats(seed=1))
    target = add_object("target", grid_splats(seed=2), location=(0.5, 0.0, 0.0))
    target.hide_render = True
    effect = source.splatline.effects.add()
    effect.type, effect.target = "MORPH", target
    _check_property(bpy, source, effect, "amount", 0.0, 1.0)


def test_gizmo_empty_transform_drives_the_field(bpy_empty):
    bpy = bpy_empty
    obj = add_object("capture", grid_splats())
    empty = bpy.data.objects.new("gizmo", None)
    bpy.context.scene.collection.objects.link(empty)
    effect = obj.splatline.effects.add()
    effect.type, effect.gizmo, effect.edge_width = "REVEAL", empty, 0.2
    empty.location = (0, 0, -0.5)
    empty.keyframe_insert("location", frame=10)
    empty.location = (0, 0, 0.5)
    empty.keyframe_insert("location", frame=20)
    states = {f: items_at(bpy, f) for f in FRAMES}
    opac = {f: states[f][0].splats.opacities for f in FRAMES}
    assert (opac[5] == opac[10]).all() and (opac[20] == opac[25]).all()
    # splats below the gizmo's plane are shown: raising the Empty shows more of them
    assert opac[10].sum() < opac[15].sum() < opac[20].sum()


def test_show_toggle_is_animatable_and_hides_the_object_from_collect_items(bpy_empty):
    bpy = bpy_empty
    obj = add_object("capture", grid_splats())
    look = obj.splatline.look
    look.keyframe_insert("visible", frame=10)
    look.visible = False
    look.keyframe_insert("visible", frame=20)
    shown = {f: len(items_at(bpy, f)) for f in FRAMES}
    assert shown == {5: 1, 10: 1, 15: 1, 20: 0, 25: 0}
    from addon.blender.evaluate.items import item_for

    hidden = item_for(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()))
    assert hidden.opacity_scale == 0.0  # a direct item_for (the viewport's path) draws nothing


def test_drivers_on_look_and_effect_parameters(bpy_empty):
    """A driver is evaluated like a keyframe: the look's opacity follows its expression,
    and a driven Reveal gives the splats of the same progress set by hand."""
    bpy = bpy_empty
    obj = add_object("capture", grid_splats())
    bpy.context.view_layer.objects.active = obj
    with bpy.context.temp_override(object=obj):
        bpy.ops.splatline.effect_add(type="REVEAL")
    for path, expression in (("splatline.effects[0].progress", "frame / 20"),
                             ("splatline.look.opacity", "0.25 + frame / 40")):
        curve = obj.driver_add(path)
        curve.driver.type, curve.driver.expression = "SCRIPTED", expression
    driven = {frame: items_at(bpy, frame)[0] for frame in (2, 10, 18)}
    obj.driver_remove("splatline.effects[0].progress")
    obj.driver_remove("splatline.look.opacity")
    for frame, item in driven.items():
        assert item.opacity_scale == pytest.approx(0.25 + frame / 40, abs=1e-6)
        obj.splatline.effects[0].progress = frame / 20
        obj.splatline.look.opacity = item.opacity_scale  # the driver's float32 rounding, exactly
        assert snapshot(items_at(bpy, frame)[0]) == snapshot(item)
    assert len({snapshot(item) for item in driven.values()}) == 3  # the driver did change them
