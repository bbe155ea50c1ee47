"""Every effect preset reaches its stated end state on the real captures, whatever the
object's transform: as imported (guitar's RDF axes sit as a rotation on the object), turned
and scaled further, and parented to a moved, turned, scaled Empty. Fields without a gizmo are
world-aligned (effect_params.gizmo_frame), so a preset must measure its bounds there too."""
from __future__ import annotations

import math

import numpy as np
import pytest
import bpy  # noqa: F401

from addon.blender.data import effect_presets
from addon.blender.data.presets import find_preset
from addon.core import effect_presets as core
from addon.core.sh import sh_to_rgb
from testing.capture_scenes import TRANSFORMS, item_at, own_item, place, world_positions

AT = 5
CAPTURES = ("guitar.ply", "test64.ply")






def _apply(bpy, obj, name, target=None):
    bpy.context.scene.frame_set(AT)
    preset = core.load(find_preset(name, "effects", ".json"))
    effect_presets.apply_preset(obj, preset, AT, target)
    return preset


def _span(preset) -> tuple[float, float]:
    frames = [f for block in [preset.look, *preset.effects] if block
              for points in block.keys.values() for f, _ in points]
    return AT + min(frames), AT + max(frames)






@pytest.mark.parametrize("transform", TRANSFORMS)
@pytest.mark.parametrize("capture", CAPTURES)
def test_sweep_reveal_shows_every_splat_at_its_own_opacity(bpy_empty, testdata, capture, transform):
    bpy = bpy_empty
    obj = place(bpy, testdata, capture, transform)
    first, last = _span(_apply(bpy, obj, "sweep_reveal"))
    own_splats = own_item(bpy, obj, last).splats
    own = own_splats.opacities
    start = item_at(bpy, obj.name_full, first).splats.opacities
    end = item_at(bpy, obj.name_full, last).splats
    assert start.sum() / own.sum() < 0.01
    shown = np.isclose(end.opacities, own, rtol=1e-6, atol=0)
    assert shown.all(), f"{shown.mean():.1%} of splats at their own opacity"
    np.testing.assert_array_equal(end.scales, own_splats.scales)
    # It sweeps up the world's Z: halfway, the shown splats sit lower than the hidden ones.
    half = item_at(bpy, obj.name_full, 0.5 * (first + last))
    z = world_positions(half)[:, 2]
    lit = half.splats.opacities.ravel() > 0.5 * own.ravel()
    assert 0 < lit.sum() < lit.size and z[lit].mean() < z[~lit].mean()


@pytest.mark.parametrize("transform", TRANSFORMS)
@pytest.mark.parametrize("capture", CAPTURES)
def test_dissolve_fade_and_glitch_reach_their_ends(bpy_empty, testdata, capture, transform):
    bpy = bpy_empty
    obj = place(bpy, testdata, capture, transform)
    first, last = _span(_apply(bpy, obj, "dissolve_out_noise"))
    own = own_item(bpy, obj, first).splats.opacities
    np.testing.assert_allclose(item_at(bpy, obj.name_full, first).splats.opacities, own, rtol=1e-6)
    assert item_at(bpy, obj.name_full, last).splats.opacities.max() == 0.0
    obj.splatline.effects.clear()
    obj.animation_data_clear()
    first, last = _span(_apply(bpy, obj, "fade_in"))
    assert (item_at(bpy, obj.name_full, first).opacity_scale, item_at(bpy, obj.name_full, first).splat_scale) == (0.0, 0.5)
    assert (item_at(bpy, obj.name_full, last).opacity_scale, item_at(bpy, obj.name_full, last).splat_scale) == (1.0, 1.0)
    first, last = _span(_apply(bpy, obj, "glitch_displace"))
    rest = own_item(bpy, obj, last).splats.positions
    np.testing.assert_array_equal(item_at(bpy, obj.name_full, last).splats.positions, rest)


@pytest.mark.parametrize("transform", TRANSFORMS)
@pytest.mark.parametrize("capture", CAPTURES)
def test_explode_bursts_from_the_centre_and_falls_down_the_world(bpy_empty, testdata, capture,
                                                                 transform):
    bpy = bpy_empty
    obj = place(bpy, testdata, capture, transform)
    first, _ = _span(_apply(bpy, obj, "explode"))
    rest = item_at(bpy, obj.name_full, first)
    np.testing.assert_array_equal(rest.splats.positions, own_item(bpy, obj, first).splats.positions)
    later = item_at(bpy, obj.name_full, first + 48)
    size = np.ptp(world_positions(rest), axis=0).max()
    moved = world_positions(later) - world_positions(rest)
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
    source = place(bpy, testdata, "guitar.ply", transform)
    target = place(bpy, testdata, "test64.ply", "imported")
    target.rotation_euler.rotate_axis("Z", math.radians(90))
    target.scale = (1.5, 1.5, 1.5)
    target.splatline.look.visible = False
    _, last = _span(_apply(bpy, source, "morph", target))
    end = item_at(bpy, source.name_full, last)
    target.splatline.look.visible = True
    want = item_at(bpy, target.name_full, last)
    assert end.splats.count == want.splats.count
    # pair each target splat with the nearest end splat (exact ties would reorder a sort)
    gap = np.linalg.norm(world_positions(want)[:, None] - world_positions(end)[None], axis=2)
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
