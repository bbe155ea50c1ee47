"""Every effect preset reaches its stated end state on the real captures, whatever the
object's transform: as imported (guitar's RDF axes sit as a rotation on the object), turned
and scaled further, and parented to a moved, turned, scaled Empty. Fields without a gizmo are
world-aligned (effect_params.gizmo_frame), so a preset must measure its bounds there too."""
from __future__ import annotations

import math

import numpy as np
import pytest
import bpy  # noqa: F401

from addon.blender.ops import effect_presets
from addon.blender.evaluate.items import collect_items
from addon.blender.data.files import import_file
from addon.blender.ops.presets import find_preset
from addon.core import effect_presets as core
from addon.core.sh import sh_to_rgb

AT = 5
CAPTURES = ("guitar.ply", "test64.ply")
TRANSFORMS = ("imported", "turned_scaled", "parented")


def _import(bpy, testdata, name, transform, suffix=""):
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


def _item(bpy, obj, frame):
    bpy.context.scene.frame_set(int(frame))
    items = collect_items(bpy.context.evaluated_depsgraph_get())
    return next(i for i in items if i.key[0] == obj.name)


def _apply(bpy, obj, name, target=None):
    bpy.context.scene.frame_set(AT)
    preset = core.load(find_preset(name, "effects", ".json"))
    effect_presets.apply_preset(obj, preset, AT, target)
    return preset


def _span(preset) -> tuple[float, float]:
    frames = [f for block in [preset.look, *preset.effects] if block
              for points in block.keys.values() for f, _ in points]
    return AT + min(frames), AT + max(frames)


def _own(bpy, obj, frame):
    """The object's splats with its effects off: each splat's own opacity."""
    for effect in obj.splatline.effects:
        effect.enabled = False
    item = _item(bpy, obj, frame)
    for effect in obj.splatline.effects:
        effect.enabled = True
    return item


def _world(item):
    return item.splats.positions.astype(np.float64) @ item.world[:3, :3].T + item.world[:3, 3]


@pytest.mark.parametrize("transform", TRANSFORMS)
@pytest.mark.parametrize("capture", CAPTURES)
def test_sweep_reveal_shows_every_splat_at_its_own_opacity(bpy_empty, testdata, capture, transform):
    bpy = bpy_empty
    obj = _import(bpy, testdata, capture, transform)
    first, last = _span(_apply(bpy, obj, "sweep_reveal"))
    own = _own(bpy, obj, last).splats.opacities
    start = _item(bpy, obj, first).splats.opacities
    end = _item(bpy, obj, last).splats
    assert start.sum() / own.sum() < 0.01
    shown = np.isclose(end.opacities, own, rtol=1e-6, atol=0)
    assert shown.all(), f"{shown.mean():.1%} of splats at their own opacity"
    np.testing.assert_array_equal(end.scales, _own(bpy, obj, last).splats.scales)
    # It sweeps up the world's Z: halfway, the shown splats sit lower than the hidden ones.
    half = _item(bpy, obj, 0.5 * (first + last))
    z = _world(half)[:, 2]
    lit = half.splats.opacities.ravel() > 0.5 * own.ravel()
    assert 0 < lit.sum() < lit.size and z[lit].mean() < z[~lit].mean()


@pytest.mark.parametrize("transform", TRANSFORMS)
@pytest.mark.parametrize("capture", CAPTURES)
def test_dissolve_fade_and_glitch_reach_their_ends(bpy_empty, testdata, capture, transform):
    bpy = bpy_empty
    obj = _import(bpy, testdata, capture, transform)
    first, last = _span(_apply(bpy, obj, "dissolve_out_noise"))
    own = _own(bpy, obj, first).splats.opacities
    np.testing.assert_allclose(_item(bpy, obj, first).splats.opacities, own, rtol=1e-6)
    assert _item(bpy, obj, last).splats.opacities.max() == 0.0
    obj.splatline.effects.clear()
    obj.animation_data_clear()
    first, last = _span(_apply(bpy, obj, "fade_in"))
    assert (_item(bpy, obj, first).opacity_scale, _item(bpy, obj, first).splat_scale) == (0.0, 0.5)
    assert (_item(bpy, obj, last).opacity_scale, _item(bpy, obj, last).splat_scale) == (1.0, 1.0)
    first, last = _span(_apply(bpy, obj, "glitch_displace"))
    rest = _own(bpy, obj, last).splats.positions
    np.testing.assert_array_equal(_item(bpy, obj, last).splats.positions, rest)


@pytest.mark.parametrize("transform", TRANSFORMS)
@pytest.mark.parametrize("capture", CAPTURES)
def test_explode_bursts_from_the_centre_and_falls_down_the_world(bpy_empty, testdata, capture,
                                                                 transform):
    bpy = bpy_empty
    obj = _import(bpy, testdata, capture, transform)
    first, _ = _span(_apply(bpy, obj, "explode"))
    rest = _item(bpy, obj, first)
    np.testing.assert_array_equal(rest.splats.positions, _own(bpy, obj, first).splats.positions)
    later = _item(bpy, obj, first + 48)
    size = np.ptp(_world(rest), axis=0).max()
    moved = _world(later) - _world(rest)
    assert np.median(np.linalg.norm(moved, axis=1)) > 0.5 * size
    fall = moved[:, 2]
    assert np.median(fall) < 0  # gravity pulls down the world's Z, not the capture's
    assert later.splats.opacities.sum() < 0.5 * rest.splats.opacities.sum()


@pytest.mark.parametrize("transform", TRANSFORMS)
def test_morph_ends_as_the_target_itself(bpy_empty, testdata, transform):
    """Source guitar (transformed), target test64 turned 90 degrees about Z and scaled:
    at the end every target splat is where the target draws it, with the target's colour
    seen from any world direction (SH rotated into the source's frame)."""
    bpy = bpy_empty
    source = _import(bpy, testdata, "guitar.ply", transform)
    target = _import(bpy, testdata, "test64.ply", "imported")
    target.rotation_euler.rotate_axis("Z", math.radians(90))
    target.scale = (1.5, 1.5, 1.5)
    target.splatline.look.visible = False
    _, last = _span(_apply(bpy, source, "morph", target))
    end = _item(bpy, source, last)
    target.splatline.look.visible = True
    want = _item(bpy, target, last)
    assert end.splats.count == want.splats.count
    # pair each target splat with the nearest end splat (exact ties would reorder a sort)
    gap = np.linalg.norm(_world(want)[:, None] - _world(end)[None], axis=2)
    order_end, order_want = gap.argmin(axis=1), np.arange(want.splats.count)
    assert gap.min(axis=1).max() < 1e-4 and len(set(order_end)) == want.splats.count
    dirs = np.random.default_rng(1).normal(size=(want.splats.count, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)

    def colours(item, order):
        s = item.splats
        local = dirs @ np.linalg.inv(item.world[:3, :3]).T  # world direction in the object
        local /= np.linalg.norm(local, axis=1, keepdims=True)
        return sh_to_rgb(s.sh_dc[order], s.sh_rest[order], local, 3)

    assert want.splats.sh_degree == 3
    np.testing.assert_allclose(colours(end, order_end), colours(want, order_want), atol=2e-4)
