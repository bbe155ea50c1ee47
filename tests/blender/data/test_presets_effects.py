"""Effect presets: each one, applied by its operator at a frame, creates the keyframes its file
describes (frames relative to that frame, values resolved against the object's bounds), and
those keys change the evaluated splats. Saving a stack as a preset and re-applying it
reproduces the keys; bad presets fail before changing anything."""
from __future__ import annotations

import json

import numpy as np
import pytest
import bpy  # noqa: F401  (puts bpy_extras on the path)
from bpy_extras import anim_utils

from addon.blender.data import effect_presets, presets
from addon.blender.ops import effect_presets as preset_ops
from addon.blender.evaluate.items import collect_items
from addon.blender.data.pointcloud import new_pointcloud_object, read_positions
from addon.core import effect_presets as core
from addon.core import procedural

FRAME = 10
BUNDLED = ("dissolve_out_noise", "explode", "fade_in", "glitch_displace", "morph", "sweep_reveal")


def _keys(obj) -> dict:
    """{(data_path, index): [(frame, value), ...]} of every F-curve on obj."""
    anim = obj.animation_data
    if anim is None or anim.action is None:
        return {}
    bag = anim_utils.action_get_channelbag_for_slot(anim.action, anim.action_slot)
    return {(c.data_path, c.array_index): [tuple(p.co) for p in c.keyframe_points]
            for c in bag.fcurves}


def _scene(bpy):
    knot = new_pointcloud_object("knot", procedural.torus_knot(3000, degree=1))
    planet = new_pointcloud_object("planet", procedural.planet(2500, degree=1))
    bpy.context.scene.frame_set(FRAME)
    return knot, planet


def _apply(bpy, obj, name, target=None):
    selected = [obj] + ([target] if target else [])
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=selected):
        return bpy.ops.splatline.effect_preset_apply(preset=name)


def _item(bpy, obj, frame):
    bpy.context.scene.frame_set(int(frame))
    items = collect_items(bpy.context.evaluated_depsgraph_get())
    return next(i for i in items if i.key[0] == obj.name)


def test_bundled_presets_listed(bpy_empty):
    assert tuple(sorted(presets.list_presets("effects", ".json"))) == BUNDLED


@pytest.mark.parametrize("name", BUNDLED)
def test_preset_creates_its_keyframes(bpy_empty, name):
    bpy = bpy_empty
    knot, planet = _scene(bpy)
    preset = core.load(presets.find_preset(name, "effects", ".json"))
    context = core.bounds_context(read_positions(knot.data), FRAME)
    assert _apply(bpy, knot, name, planet if name == "morph" else None) == {"FINISHED"}
    keys = _keys(knot)
    blocks = ([("splatline.look", preset.look)] if preset.look else []) + [
        (f"splatline.effects[{i}]", b) for i, b in enumerate(preset.effects)]
    assert len(knot.splatline.effects) == len(preset.effects)
    for path, block in blocks:
        for prop, points in block.keys.items():
            got = keys[(f"{path}.{prop}", 0)]
            assert [f for f, _ in got] == [FRAME + off for off, _ in points]
            want = [core.resolve(v, context) for _, v in points]
            np.testing.assert_allclose([v for _, v in got], want, rtol=1e-6, atol=1e-6)
    # Exactly the described curves, nothing else keyed.
    described = {f"{p}.{prop}" for p, b in blocks for prop in b.keys}
    assert {path for path, _ in keys} == described


@pytest.mark.parametrize("name", BUNDLED)
def test_preset_keys_change_the_evaluated_splats(bpy_empty, name):
    bpy = bpy_empty
    knot, planet = _scene(bpy)
    preset = core.load(presets.find_preset(name, "effects", ".json"))
    block = (preset.effects or [preset.look])[0]
    offsets = sorted({off for points in block.keys.values() for off, _ in points})
    before = _item(bpy, knot, FRAME + offsets[-1])
    bpy.context.scene.frame_set(FRAME)
    _apply(bpy, knot, name, planet if name == "morph" else None)
    frames = [FRAME + off for off in offsets]
    items = [_item(bpy, knot, f) for f in frames]
    changed = [_differs(a, b) for a, b in zip(items, items[1:])]
    assert any(changed), f"{name}: keys at {frames} change nothing"
    assert any(_differs(item, before) for item in items), f"{name}: same as without the preset"


def _differs(a, b) -> bool:
    sa, sb = a.splats, b.splats
    if sa.count != sb.count or a.opacity_scale != b.opacity_scale or a.splat_scale != b.splat_scale:
        return True
    return any(not np.array_equal(x, y) for x, y in
               ((sa.positions, sb.positions), (sa.opacities, sb.opacities), (sa.scales, sb.scales),
                (sa.sh_dc, sb.sh_dc)))


def test_morph_without_target_changes_nothing(bpy_empty):
    bpy = bpy_empty
    knot, _ = _scene(bpy)
    with pytest.raises(RuntimeError, match="target"):
        _apply(bpy, knot, "morph")
    assert len(knot.splatline.effects) == 0 and not _keys(knot)


def test_saved_preset_reapplies_same_keys(bpy_empty, tmp_path, monkeypatch):
    bpy = bpy_empty
    knot, planet = _scene(bpy)
    _apply(bpy, knot, "glitch_displace")
    _apply(bpy, knot, "sweep_reveal")
    data = effect_presets.capture_preset(knot, FRAME, "Mine")
    path = tmp_path / "mine.json"
    path.write_text(json.dumps(data))
    effect_presets.apply_preset(planet, core.load(path), FRAME + 5)
    theirs = {(p, i): [(f - 5, v) for f, v in pts] for (p, i), pts in _keys(planet).items()}
    mine = _keys(knot)
    assert theirs.keys() == mine.keys()
    for key in mine:
        np.testing.assert_allclose(theirs[key], mine[key], rtol=1e-6)
    assert [e.type for e in planet.splatline.effects] == [e.type for e in knot.splatline.effects]


def test_core_rejects_bad_presets(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"effects": [{"type": "REVEAL", "keys": {"progress": [[0, "size + open(1)"]]}}]}')
    preset = core.load(bad)
    with pytest.raises(ValueError, match="unsupported expression"):
        core.resolve(preset.effects[0].keys["progress"][0][1], {"size": 1.0})
    bad.write_text('{"effects": [{"type": "REVEAL", "interpolation": "SPLINE"}]}')
    with pytest.raises(core.PresetError, match="bad.json"):
        core.load(bad)
    bad.write_text("{")
    with pytest.raises(core.PresetError, match="bad.json"):
        core.load(bad)
    assert core.resolve("zmax + 0.1 * size", {"zmax": 2.0, "size": 10.0}) == pytest.approx(3.0)


# --- What each bundled preset does for a user: expectations written by hand, not read from
# its file, applied at a frame that is neither 0 nor 1 so relative keys are checked too.

AT = 37


def _applied(bpy, name, target=True):
    knot, planet = _scene(bpy)
    bpy.context.scene.frame_set(AT)
    assert _apply(bpy, knot, name, planet if target else None) == {"FINISHED"}
    return knot, planet


def test_fade_in_goes_from_transparent_to_opaque_over_24_frames(bpy_empty):
    bpy = bpy_empty
    knot, _ = _applied(bpy, "fade_in", target=False)
    opacity = _keys(knot)[("splatline.look.opacity", 0)]
    assert [f for f, _ in opacity] == [37, 61]
    assert [v for _, v in opacity] == pytest.approx([0.0, 1.0])
    assert _item(bpy, knot, 37).opacity_scale == pytest.approx(0.0)
    assert _item(bpy, knot, 61).opacity_scale == pytest.approx(1.0)
    assert len(knot.splatline.effects) == 0


def _reveal_fractions(bpy, obj, first, last):
    """Evaluated opacity at the first and last key, relative to the capture's own."""
    obj.splatline.effects[0].enabled = False
    full = _item(bpy, obj, first).splats.opacities.sum()
    obj.splatline.effects[0].enabled = True
    return (_item(bpy, obj, first).splats.opacities.sum() / full,
            _item(bpy, obj, last).splats.opacities.sum() / full)


def test_dissolve_out_noise_starts_whole_and_ends_gone(bpy_empty):
    bpy = bpy_empty
    knot, _ = _applied(bpy, "dissolve_out_noise", target=False)
    (effect,) = knot.splatline.effects
    assert (effect.type, effect.reveal_shape) == ("REVEAL", "NOISE")
    assert effect.glow_strength > 0  # "with a glowing edge"
    frames = [f for f, _ in _keys(knot)[("splatline.effects[0].progress", 0)]]
    assert frames == [37, 73]  # 1.5 s at 24 fps
    start, end = _reveal_fractions(bpy, knot, 37, 73)
    assert start > 0.99 and end < 0.01, (start, end)


def test_sweep_reveal_sweeps_in_from_the_bottom(bpy_empty):
    bpy = bpy_empty
    knot, _ = _applied(bpy, "sweep_reveal", target=False)
    (effect,) = knot.splatline.effects
    assert (effect.type, effect.reveal_shape, effect.invert) == ("REVEAL", "PLANE", False)
    frames = [f for f, _ in _keys(knot)[("splatline.effects[0].progress", 0)]]
    assert frames == [37, 85]
    start, end = _reveal_fractions(bpy, knot, 37, 85)
    assert start < 0.01 and end > 0.99, (start, end)
    half = _item(bpy, knot, 61).splats
    shown = half.opacities.ravel() > 0.5 * half.opacities.max()
    z = half.positions[:, 2]
    assert 0 < shown.sum() < len(z) and z[shown].mean() < z[~shown].mean()  # lower half first


def test_explode_starts_at_the_current_frame(bpy_empty):
    bpy = bpy_empty
    knot, _ = _applied(bpy, "explode", target=False)
    (effect,) = knot.splatline.effects
    size = core.bounds_context(read_positions(knot.data), AT)["size"]
    assert effect.type == "EXPLODE" and effect.explode_mode == "CENTER"
    assert effect.start_frame == pytest.approx(37.0)  # "start_frame": "frame"
    assert (effect.strength, effect.gravity) == pytest.approx((size, size))
    assert (effect.spread, effect.spin, effect.fade, effect.seed) == pytest.approx((0.5, 4.0, 0.6, 3))
    rest = _item(bpy, knot, 37).splats.positions
    later = _item(bpy, knot, 49).splats.positions
    centre = rest.mean(axis=0)
    assert np.linalg.norm(later - centre, axis=1).mean() > 1.2 * np.linalg.norm(rest - centre, axis=1).mean()


def test_glitch_displace_steps_with_constant_keys(bpy_empty):
    bpy = bpy_empty
    knot, _ = _applied(bpy, "glitch_displace", target=False)
    (effect,) = knot.splatline.effects
    assert effect.type == "DISPLACE" and effect.speed == pytest.approx(8.0)
    anim = knot.animation_data
    bag = anim_utils.action_get_channelbag_for_slot(anim.action, anim.action_slot)
    curve = bag.fcurves.find("splatline.effects[0].amplitude")
    assert curve.keyframe_points[0].co[0] == 37
    assert {p.interpolation for p in curve.keyframe_points} == {"CONSTANT"}
    rest = _item(bpy, knot, 37).splats.positions
    # Held at 0 until the key at 39 (a Bezier would already be rising at 38), then a jump.
    assert np.array_equal(_item(bpy, knot, 38).splats.positions, rest)
    assert not np.allclose(_item(bpy, knot, 39).splats.positions, rest)


def test_morph_turns_into_the_other_selected_object(bpy_empty):
    bpy = bpy_empty
    knot, planet = _applied(bpy, "morph")
    (effect,) = knot.splatline.effects
    assert effect.type == "MORPH" and effect.target == planet
    assert _item(bpy, knot, 37).splats.count == len(knot.data.points)
    end = _item(bpy, knot, 85).splats  # 2 s later: the planet itself
    want = read_positions(planet.data)
    assert end.count == len(want)
    np.testing.assert_allclose(np.sort(end.positions, axis=0), np.sort(want, axis=0), atol=1e-4)


# --- Bad user presets fail whole, with a report; saving and removing through the operators.

@pytest.fixture
def user_presets(monkeypatch, tmp_path):
    """Blender's user preset folders moved into tmp_path (never the real user's config)."""
    monkeypatch.setenv("BLENDER_USER_SCRIPTS", str(tmp_path / "scripts"))
    folder = tmp_path / "scripts" / "presets" / "splatline" / "effects"
    folder.mkdir(parents=True)
    assert effect_presets.user_dir() == folder
    return folder


class _Recorder:
    """Stands in for the operator instance, to see execute's result and its reports (bpy.ops
    turns an ERROR report into RuntimeError and drops the result)."""

    def __init__(self, **props):
        self.__dict__.update(props)
        self.reports = []

    def report(self, level, message):
        self.reports.append((set(level), message))


def _state(obj) -> tuple:
    """Everything a preset may change on obj: effect stack, look, keyframes, active effect."""
    def values(group):
        return {k: (list(v) if hasattr(v, "__len__") and not isinstance(v, str) else v)
                for k in group.bl_rna.properties.keys() if k != "rna_type"
                for v in [getattr(group, k)]}
    return ([values(e) for e in obj.splatline.effects], values(obj.splatline.look), _keys(obj),
            obj.splatline.active_effect, obj.animation_data is None)


BAD = {  # name -> (preset JSON, what the error must say)
    "bad_enum": ({"look": {"keys": {"opacity": [[0, 0.0], [10, 1.0]]}},
                  "effects": [{"type": "DISPLACE", "keys": {"amplitude": [[0, 0.0], [5, 1.0]]}},
                              {"type": "REVEAL", "set": {"reveal_shape": "WEDGE"}}]},
                 "WEDGE"),
    "bad_property": ({"effects": [{"type": "TWIST", "set": {"twist": 1.0}},
                                  {"type": "REVEAL", "keys": {"no_such": [[0, 1.0]]}}]},
                     "no_such"),
    "bad_type": ({"effects": [{"type": "GRADE"}], "look": {"set": {"opacity": "half"}}}, "opacity"),
    "bad_type_name": ({"effects": [{"type": "EXPLODE"}, {"type": "SHATTER"}]}, "SHATTER"),
}


@pytest.mark.parametrize("name", sorted(BAD))
@pytest.mark.parametrize("prior", ["fresh", "keyed"])
def test_bad_user_preset_changes_nothing_and_reports(bpy_empty, user_presets, name, prior):
    bpy = bpy_empty
    data, says = BAD[name]
    (user_presets / f"{name}.json").write_text(json.dumps(data))
    knot, _ = _scene(bpy)
    if prior == "keyed":
        _apply(bpy, knot, "glitch_displace")
    before, counts = _state(knot), (len(bpy.data.objects), len(bpy.data.actions))
    with pytest.raises(RuntimeError) as failed:
        _apply(bpy, knot, name)
    assert name in str(failed.value) and says in str(failed.value)
    assert "Traceback" not in str(failed.value)
    assert _state(knot) == before
    assert (len(bpy.data.objects), len(bpy.data.actions)) == counts  # no scratch left behind
    op = _Recorder(preset=name)
    with bpy.context.temp_override(active_object=knot, object=knot, selected_objects=[knot]):
        assert preset_ops.SPLATLINE_OT_effect_preset_apply.execute(op, bpy.context) == {"CANCELLED"}
    ((level, message),) = op.reports
    assert level == {"ERROR"} and name in message and says in message
    assert _state(knot) == before


def _save(bpy, obj, name):
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj]):
        return bpy.ops.splatline.effect_preset_add(name=name)


def test_save_reapply_and_remove_a_user_preset(bpy_empty, user_presets):
    bpy = bpy_empty
    knot, planet = _scene(bpy)
    _apply(bpy, knot, "sweep_reveal")
    _apply(bpy, knot, "glitch_displace")
    assert _save(bpy, knot, "My Glitch") == {"FINISHED"}
    path = user_presets / "my_glitch.json"
    assert path.is_file() and presets.list_presets("effects", ".json")["my_glitch"] == path
    bpy.context.scene.frame_set(FRAME + 7)
    assert _apply(bpy, planet, "my_glitch") == {"FINISHED"}
    theirs = {k: [(f - 7, v) for f, v in pts] for k, pts in _keys(planet).items()}
    assert theirs.keys() == _keys(knot).keys()
    for key, points in _keys(knot).items():
        np.testing.assert_allclose(theirs[key], points, rtol=1e-6)
    for a, b in zip(planet.splatline.effects, knot.splatline.effects):
        assert (a.type, a.reveal_shape, a.seed, a.glow_strength) == (b.type, b.reveal_shape, b.seed, b.glow_strength)
    assert bpy.ops.splatline.effect_preset_remove(preset="my_glitch") == {"FINISHED"}
    assert not path.exists() and "my_glitch" not in presets.list_presets("effects", ".json")


def test_bundled_effect_presets_cannot_be_removed(bpy_empty, user_presets):
    bpy = bpy_empty
    with pytest.raises(RuntimeError, match="bundled"):
        bpy.ops.splatline.effect_preset_remove(preset="fade_in")
    victim = user_presets.parent / "victim.json"  # outside the effect preset folder
    victim.write_text("{}")
    with pytest.raises(RuntimeError, match="not a user preset"):
        bpy.ops.splatline.effect_preset_remove(preset="../victim")
    assert victim.is_file() and presets.find_preset("fade_in", "effects", ".json").is_file()


def test_saving_where_it_cannot_write_reports(bpy_empty, user_presets):
    bpy = bpy_empty
    knot, _ = _scene(bpy)
    _apply(bpy, knot, "explode")
    (user_presets / "blocked.json").mkdir()  # writing the preset file then fails
    with pytest.raises(RuntimeError) as failed:
        _save(bpy, knot, "Blocked")
    assert "cannot save effect preset 'Blocked'" in str(failed.value)
    assert "Traceback" not in str(failed.value)
    op = _Recorder(name="Blocked")
    with bpy.context.temp_override(active_object=knot, object=knot, selected_objects=[knot]):
        assert preset_ops.SPLATLINE_OT_effect_preset_add.execute(op, bpy.context) == {"CANCELLED"}
    assert [level for level, _ in op.reports] == [{"ERROR"}]
