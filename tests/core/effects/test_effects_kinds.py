"""Effects describe themselves (core/effects/kind.py, registry.py): an effect added through
its description alone is offered, evaluated, cached and invalidated like the built-in ones,
and every registered kind's flags say what its kernel really does on a real capture."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pytest

from addon.core.effects import EffectParams, KINDS, registry
from addon.core.effects.kind import EffectKind, Field
from testing.capture_scenes import item_at, own_item, place
from testing.effect_ops import add_effect as _add  # an effect through the real operator
from testing.viewport_scene import camera_for, draw_offscreen, overlay_drawn, psnr

ARRAYS = ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")


# -- a throwaway effect: a kernel and its description, nothing else -----------------------
@dataclass
class Bob(EffectParams):
    lift: float = 0.2   # object units
    rate: float = 1.0   # radians per second


def bob(splats, p: Bob, time: float = 0.0, rest=None):
    """Every splat bobs along object z by amount * lift * sin(rate * time)."""
    if not p.active or splats.count == 0:
        return splats
    positions = splats.positions.copy()
    positions[:, 2] += np.float32(p.amount * p.lift * math.sin(p.rate * time))
    return replace(splats, positions=positions)


BOB = EffectKind("TEST_BOB", 90, "Bob", "Splats bob up and down", "MOD_WAVE", Bob, bob,
                 moves_splats=True, depends_on_time=True, fields=(
                     Field("bob_lift", "FLOAT", "Lift", 0.2, param="lift", options={"min": 0.0}),
                     Field("bob_rate", "FLOAT", "Rate", 1.0, param="rate")))


def _reregister(bpy):
    from addon import register, unregister

    bpy.ops.wm.read_factory_settings(use_empty=True)  # no item holds the type being dropped
    unregister()
    register()


@pytest.fixture
def with_bob(bpy_empty):
    registry.add(BOB)
    try:
        _reregister(bpy_empty)
        yield bpy_empty
    finally:
        registry.remove(BOB.id)
        _reregister(bpy_empty)


def _expected(rest, effect, frame, fps=24.0):
    """The kernel's own output; lift and rate as Blender stores them (float32)."""
    return bob(rest.splats, Bob(lift=effect.bob_lift, rate=effect.bob_rate), frame / fps).positions


def test_a_throwaway_effect_is_offered_from_its_description(with_bob):
    from addon.blender.props.effect import FIELDS

    bpy = with_bob
    menu = bpy.ops.splatline.effect_add.get_rna_type().properties["type"].enum_items
    assert ("TEST_BOB", "Bob", 90) in {(i.identifier, i.name, i.value) for i in menu}
    assert FIELDS["TEST_BOB"] == ("bob_lift", "bob_rate")
    lift = bpy.types.Object.bl_rna.properties["splatline"].fixed_type.properties["effects"] \
        .fixed_type.properties["bob_lift"]
    assert (lift.name, lift.default, lift.hard_min, lift.is_animatable) == \
        ("Lift", pytest.approx(0.2), 0.0, True)


def test_a_throwaway_effect_is_evaluated_cached_and_invalidated(with_bob, testdata, renderer):
    bpy = with_bob
    obj = overlay_drawn(place(bpy, testdata, "guitar.ply"))  # real capture, real transform
    effect = _add(bpy, obj, "TEST_BOB", bob_lift=0.3, bob_rate=2.0)
    rest = own_item(bpy, obj, 12)
    a = item_at(bpy, obj.name_full, 12)
    # evaluated through collect_items, bit for bit the kernel's output at time = frame / fps
    np.testing.assert_array_equal(a.splats.positions, _expected(rest, effect, 12))
    for name in ARRAYS[1:]:
        assert getattr(a.splats, name) is getattr(rest.splats, name)  # copy-on-write
    assert a.positions_key != a.key[:2]  # moves splats: not the base's (name, key)

    # cached: the same frame again is the same key, and the GL renderer reuses its upload
    cam = camera_for(a.world[:3, 3], 64, 48)
    renderer.render([a], cam)
    uploads = renderer.stats["geometry_uploads"]
    b = item_at(bpy, obj.name_full, 12)
    assert (b.key, b.positions_key) == (a.key, a.positions_key)
    assert b.splats.sh_rest is a.splats.sh_rest  # the base splats came from the cache
    renderer.render([b], cam)
    assert renderer.stats["geometry_uploads"] == uploads

    # invalidated by a frame change (depends on time, no keyframes) and by a property edit
    c = item_at(bpy, obj.name_full, 13)
    np.testing.assert_array_equal(c.splats.positions, _expected(rest, effect, 13))
    effect.bob_lift = 0.5
    d = item_at(bpy, obj.name_full, 13)
    np.testing.assert_array_equal(d.splats.positions, _expected(rest, effect, 13))
    keys = [(i.key, i.positions_key) for i in (a, c, d)]
    assert len({k for k, _ in keys}) == 3 and len({p for _, p in keys}) == 3
    for item in (c, d):
        renderer.render([item], cam)
    assert renderer.stats["geometry_uploads"] == uploads + 2

    # the viewport re-packs and re-sorts the moved centres, and draws what a fresh one does
    from addon.blender.viewport import ViewportRenderer
    from testing.headless import ensure_gpu

    ensure_gpu()
    viewport = ViewportRenderer()
    draw_offscreen([a], cam, renderer=viewport)
    sorts = viewport.stats.sorts
    for n, item in enumerate((c, d), 1):
        img, _ = draw_offscreen([item], cam, renderer=viewport)
        assert viewport.stats.sorts == sorts + n
        assert psnr(img, draw_offscreen([item], cam)[0]) == float("inf")


def test_a_clashing_description_is_refused_in_one_line():
    clashes = {"id": replace(BOB, id="TWIST"), "number": replace(BOB, number=KINDS["TWIST"].number),
               "field": replace(BOB, fields=(Field("seed", "FLOAT", "Seed", 0.0),))}
    for what, kind in clashes.items():
        with pytest.raises(ValueError, match=what) as caught:
            registry.add(kind)
        assert "\n" not in str(caught.value)
    assert "TEST_BOB" not in KINDS


def test_a_preset_asks_for_a_second_object_from_the_kinds_target_field():
    """Presets and `import --effect-preset` ask for a second object when an effect has a
    SPLATS field, whatever its type or the field's name, not when the type is MORPH."""
    from addon.core import effect_presets

    pull = replace(BOB, id="TEST_PULL", number=91, params=type("Pull", (Bob,), {}),
                   fields=(Field("pull_toward", "SPLATS", "Toward", derived=True),))
    registry.add(pull)
    try:
        preset = effect_presets.parse("pull", {"effects": [{"type": "TEST_PULL"}]})
        assert preset.effects[0].target_field == "pull_toward"
        assert preset.needs_target
    finally:
        registry.remove(pull.id)
    assert not effect_presets.parse("bob", {"effects": [{"type": "TWIST"}]}).needs_target
    assert effect_presets.parse("morph", {"effects": [{"type": "MORPH"}]}).needs_target


# -- every registered kind: its flags match what its kernel does -------------------------
def _variants(kind):
    """The kind's defaults, then each other item of each of its enum fields."""
    yield {}
    for f in kind.fields:
        if f.type == "ENUM":
            for item in f.items[1:]:
                yield {f.name: item[0]}


@pytest.mark.parametrize("kind_id", sorted(KINDS))
def test_every_kinds_flags_match_its_kernel_on_a_real_capture(bpy_empty, testdata, kind_id):
    """moves_splats: some setting moves the centres, or none ever does; depends_on_time:
    some setting changes the output between two frames with no keyframes, or none does."""
    bpy, kind = bpy_empty, KINDS[kind_id]
    obj = place(bpy, testdata, "guitar.ply", "turned_scaled")
    other = place(bpy, testdata, "test64.ply", suffix=".target")
    effect = _add(bpy, obj, kind_id, amount=0.5)
    for f in kind.fields:
        if f.type == "SPLATS":
            setattr(effect, f.name, other)
    moved = timed = False
    for variant in _variants(kind):
        for name, value in variant.items():
            setattr(effect, name, value)
        rest = own_item(bpy, obj, 30)
        early, late = item_at(bpy, obj.name_full, 30), item_at(bpy, obj.name_full, 60)
        assert any(not np.array_equal(getattr(early.splats, n), getattr(rest.splats, n))
                   for n in ARRAYS), f"{kind_id} {variant}: the effect did nothing"
        moved |= not np.array_equal(early.splats.positions, rest.splats.positions) or \
            not np.array_equal(late.splats.positions, rest.splats.positions)
        timed |= any(not np.array_equal(getattr(early.splats, n), getattr(late.splats, n))
                     for n in ARRAYS)
        # the evaluator's keys follow the flags: positions keyed apart from the base's own
        # (name, key) only when moved (5.3's handoff may bump the base key between reads)
        assert (early.positions_key != early.key[:2]) == kind.moves_splats
        assert (early.key != late.key) == kind.depends_on_time
    assert moved == kind.moves_splats, f"{kind_id}: moves_splats={kind.moves_splats} but moved={moved}"
    assert timed == kind.depends_on_time, f"{kind_id}: depends_on_time={kind.depends_on_time}"


# -- the property group is the table ------------------------------------------------------
_RNA_TYPES = {"FLOAT": "FLOAT", "INT": "INT", "BOOL": "BOOLEAN", "ENUM": "ENUM", "COLOR": "FLOAT",
              "SPLATS": "POINTER"}


def test_the_effect_property_group_is_built_from_the_table(_bpy_registered):
    """Every field is one property (animatable but for object pointers) of its declared type,
    label, default and options, and the type menu is the table; the values saved files hold
    never move."""
    from addon.blender.props.effect import Effect

    props = Effect.bl_rna.properties
    assert {(i.identifier, i.value) for i in props["type"].enum_items} == \
        {(k.id, k.number) for k in KINDS.values()}
    assert {k.id: k.number for k in KINDS.values()} == {
        "REVEAL": 0, "DISPLACE": 1, "EXPLODE": 2, "TWIST": 3, "GRADE": 4, "MORPH": 5}
    fields = registry.all_fields()
    own = {p.identifier for p in props} - {"rna_type", "name", "type", "enabled", "amount", "gizmo"}
    assert own == {f.name for f in fields}
    for f in fields:
        prop = props[f.name]
        assert (prop.type, prop.name, prop.description) == (_RNA_TYPES[f.type], f.label, f.description)
        assert prop.is_animatable == (f.type != "SPLATS"), f.name  # object pointers never are
        if f.type == "ENUM":
            assert [(i.identifier, i.name, i.description) for i in prop.enum_items] == list(f.items)
        elif f.type == "COLOR":
            assert prop.subtype == "COLOR" and tuple(prop.default_array) == pytest.approx(f.default)
        elif f.type != "SPLATS":
            assert prop.default == pytest.approx(f.default), f.name
        for option, value in f.options.items():
            rna = {"min": "hard_min", "max": "hard_max"}.get(option, option)
            assert getattr(prop, rna) == pytest.approx(value) if isinstance(value, float) \
                else getattr(prop, rna) == value, (f.name, option)
