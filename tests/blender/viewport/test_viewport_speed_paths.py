"""The viewport's scrubbing paths (issue 29): the pos and shape textures kept on the CPU
and rewritten per part (staging.py), the opacity-only update that rewrites the GPU pos
texture's alpha channel in place, drawable() a field at a time and halves_fast. Each is
pinned to what it replaces: the packing references (pack_pos, pack_shape, drawable,
halves), the uploaded texels and the drawn pixels of a full upload."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from addon.blender.viewport import packing
from addon.blender.viewport.staging import ALL, ALPHA, NOTHING, PosStage, ShapeStage
from addon.core.formats import read
from addon.core.scene import RenderItem
from testing.viewport_scene import camera_for, draw_offscreen, psnr, two_objects


def _with_undrawable(splats, seed: int):
    """A copy with some splats no renderer draws (zero quaternion, non-finite scale)."""
    rng = np.random.default_rng(seed)
    rotations, scales = splats.rotations.copy(), splats.scales.copy()
    rotations[rng.choice(splats.count, 5, replace=False)] = 0.0
    scales[rng.choice(splats.count, 3, replace=False), 1] = np.inf
    return replace(splats, rotations=rotations, scales=scales)


def _reference(items) -> np.ndarray:
    """pack_pos of every object, concatenated: what a full upload sends."""
    parts = [packing.pack_pos(i.splats, packing.drawable(i.splats, 3)) for i in items]
    counts = [i.splats.count for i in items]
    return packing.concatenate(parts, counts, 4)


def _parts(items, valid):
    return [(i.key, i.splats.positions, i.key, i.splats.opacities, v) for i, v in zip(items, valid)]


def test_staging_matches_a_full_pack_through_every_kind_of_change(testdata):
    capture = _with_undrawable(read(testdata / "test64.ply"), seed=1)
    guitar = read(testdata / "guitar.ply")
    items = [RenderItem(capture, key=("a", 0)), RenderItem(guitar, key=("b", 0))]
    stage, valids = PosStage(), {}
    rng = np.random.default_rng(2)

    def step(new_items, expected):
        # the renderer keeps drawable()'s mask while its sources stay: so does this
        valid = [valids.setdefault((i.key, id(i.splats.rotations), id(i.splats.scales)),
                                   packing.drawable(i.splats, 3)) for i in new_items]
        assert stage.update(_parts(new_items, valid)) == expected
        np.testing.assert_array_equal(stage.flat, _reference(new_items))
        if expected == ALPHA:
            np.testing.assert_array_equal(stage.alpha, stage.flat[:, 3])
        return new_items

    items = step(items, ALL)
    items = step(items, NOTHING)
    faded = replace(items[1].splats, opacities=(items[1].splats.opacities * 0.5).astype(np.float32))
    items = step([items[0], replace(items[1], splats=faded)], ALPHA)
    moved = replace(items[0].splats, positions=items[0].splats.positions + rng.normal(0, 0.1, (64, 3))
                    .astype(np.float32))
    items = step([replace(items[0], splats=moved), items[1]], ALL)
    items = step([replace(items[0], key=("a", 1)), items[1]], ALL)  # a new geometry version
    items = step([items[1], items[0]], ALL)  # another layout
    items = step(items[:1], ALL)


def _pos_texels(renderer) -> np.ndarray:
    texture = renderer.gpu.textures["pos"]
    return np.array(texture.read().to_list(), np.float32).reshape(-1, 4)


def test_an_opacity_change_uploads_only_the_alpha_and_draws_what_a_full_upload_does(testdata, gpu_ready):
    from addon.blender.viewport import ViewportRenderer

    items, centre = two_objects(testdata)
    items = [replace(items[0], splats=_with_undrawable(items[0].splats, seed=3), key=("a", 0)),
             replace(items[1], key=("b", 0))]
    cam = camera_for(centre)
    r = ViewportRenderer()
    draw_offscreen(items, cam, renderer=r)
    sorts, uploads = r.stats.sorts, r.stats.uploads
    s = items[0].splats
    faded = replace(s, opacities=np.linspace(0.05, 1.0, s.count, dtype=np.float32))
    changed = [replace(items[0], splats=faded), items[1]]  # same key, positions and order
    img, _ = draw_offscreen(changed, cam, renderer=r)
    total = sum(i.splats.count for i in items)
    assert r.stats.alpha_uploads == 1 and r.stats.uploads == uploads + 1 and r.stats.sorts == sorts
    assert r.stats.frame_bytes == 4 * packing.padded(total), "only the alpha channel goes up"
    texels = _pos_texels(r)
    np.testing.assert_array_equal(texels, _reference(changed))  # NaN marks where it was
    fresh, full = draw_offscreen(changed, cam)
    assert full.stats.alpha_uploads == 0
    np.testing.assert_array_equal(texels, _pos_texels(full))
    assert psnr(img, fresh) == float("inf")
    assert psnr(img, draw_offscreen(items, cam)[0]) < 60.0  # the change shows


def test_a_reveal_without_shrink_or_glow_reaches_the_viewport_as_an_opacity_change(bpy_empty, gpu_ready):
    """What the effect evaluation hands the viewport: a Reveal that only fades keeps the
    base positions array and the positions key, so scrubbing it uploads the alpha alone."""
    from addon.blender.viewport import ViewportRenderer
    from testing.animation_scene import add_object, grid_splats, items_at

    bpy = bpy_empty
    obj = add_object("capture", grid_splats(n_side=8))
    bpy.context.view_layer.objects.active = obj
    with bpy.context.temp_override(object=obj):
        bpy.ops.splatline.effect_add(type="REVEAL")
    reveal = obj.splatline.effects[0]
    reveal.shrink = 0.0
    reveal.glow_strength = 0.0
    for frame, progress in ((1, -1.0), (20, 1.0)):
        reveal.progress = progress
        reveal.keyframe_insert("progress", frame=frame)
    eye = np.array([0.3, -6.0, 0.8])
    from addon.core.camera import look_at, simple_camera

    cam = simple_camera(64, 48, 45.0, look_at(eye, (0, 0, 0)), near=0.05, far=50.0)
    r = ViewportRenderer()
    first = items_at(bpy, 8)
    draw_offscreen(first, cam, renderer=r)
    sorts = r.stats.sorts
    later = items_at(bpy, 12)
    assert later[0].positions_key == first[0].positions_key
    assert later[0].splats.positions is first[0].splats.positions
    img, _ = draw_offscreen(later, cam, renderer=r)
    assert r.stats.alpha_uploads == 1 and r.stats.sorts == sorts
    assert r.stats.frame_bytes == 4 * packing.padded(later[0].splats.count)
    assert psnr(img, draw_offscreen(later, cam)[0]) == float("inf")


@pytest.mark.parametrize("degree", [0, 1, 2, 3])
def test_drawable_a_field_at_a_time_matches_drawable(testdata, degree):
    """The viewport's per-field masks, ANDed, are packing.drawable, whatever is broken."""
    s = read(testdata / "test64.ply")  # degree 3
    rng = np.random.default_rng(degree)
    rotations, scales, dc, rest = s.rotations.copy(), s.scales.copy(), s.sh_dc.copy(), s.sh_rest.copy()
    rotations[3] = 0.0
    rotations[5, 2] = np.nan
    rotations[7, 0] = -np.inf
    scales[9, 1] = np.inf
    dc[11, 2] = np.nan
    rest[13, 2, 1] = np.nan      # band 1: matters from degree 1
    rest[15, 10, 0] = np.inf     # band 3: matters at degree 3 only
    broken = replace(s, rotations=rotations, scales=scales, sh_dc=dc, sh_rest=rest)
    for splats in (s, broken, replace(broken, rotations=rng.normal(size=(64, 4)).astype(np.float32))):
        ok = (packing.rotation_rows(splats.rotations) & packing.finite_rows(splats.scales)
              & packing.finite_rows(splats.sh_dc) & packing.rest_rows(splats, degree))
        np.testing.assert_array_equal(ok, packing.drawable(splats, degree))
    assert not packing.drawable(broken, degree)[[3, 5, 7, 9, 11]].any()


def test_shape_stage_matches_pack_shape_through_every_kind_of_change(testdata):
    capture = _with_undrawable(read(testdata / "test64.ply"), seed=4)
    guitar = read(testdata / "guitar.ply")
    items = [RenderItem(capture, key=("a", 0)), RenderItem(guitar, key=("b", 0))]
    stage = ShapeStage()
    rng = np.random.default_rng(5)
    fields = ("rotations", "scales", "sh_dc")

    def step(new_items, changed):
        parts = [tuple((i.key, getattr(i.splats, f)) for f in fields) for i in new_items]
        assert stage.update(parts) == changed
        reference = packing.concatenate([packing.pack_shape(i.splats) for i in new_items],
                                        [i.splats.count for i in new_items], packing.SHAPE_VALUES)
        np.testing.assert_array_equal(stage.flat, reference)
        return new_items

    def changed_field(item, field, values):
        return replace(item, splats=replace(item.splats, **{field: values}))

    items = step(items, True)
    items = step(items, False)
    g = items[1].splats
    items = step([items[0], changed_field(items[1], "sh_dc", g.sh_dc * np.float32(1.5))], True)
    items = step([items[0], changed_field(items[1], "scales", g.scales * np.float32(0.5))], True)
    turned = rng.normal(size=(g.count, 4)).astype(np.float32)  # every component the largest somewhere
    items = step([items[0], changed_field(items[1], "rotations", turned)], True)
    items = step([items[0], changed_field(items[1], "scales", np.zeros_like(g.scales))], True)  # HALF_TINY
    items = step([replace(items[0], key=("a", 1)), items[1]], True)  # a new geometry version
    items = step([items[1], items[0]], True)  # another layout


def test_halves_fast_is_halves_bit_for_bit():
    """Every half and the float32 values at, beside and between consecutive halves (the
    ties round to even), specials, and 4M random float32 bit patterns."""
    every = np.arange(1 << 16, dtype=np.uint32).astype(np.uint16).view(np.float16).astype(np.float32)
    h = np.unique(every[np.isfinite(every)])
    mid = ((h[1:].astype(np.float64) + h[:-1]) / 2).astype(np.float32)  # exact in float32
    up, down = np.float32(np.inf), np.float32(-np.inf)
    values = [h, mid, np.nextafter(mid, up), np.nextafter(mid, down), np.nextafter(h, up), np.nextafter(h, down),
              np.array([np.nan, -np.nan, np.inf, -np.inf, 65519.99, 65520.0, 1e30, -1e30, -0.0, 1e-45], np.float32),
              np.random.default_rng(0).integers(0, 1 << 32, 4_000_000, dtype=np.uint64).astype(np.uint32)
              .view(np.float32)]
    x = np.concatenate(values)
    np.testing.assert_array_equal(packing.halves_fast(x).view(np.uint32), packing.halves(x).view(np.uint32))
    grid = x[:x.size // 4 * 4].reshape(-1, 4)  # any shape, not only 1-D
    np.testing.assert_array_equal(packing.halves_fast(grid).view(np.uint32), packing.halves(grid).view(np.uint32))


def test_halves_into_stream_columns_is_halves_and_shape_scales_bit_for_bit():
    """The staging path: rows in blocks on two threads, written into three columns of a
    wider stream, as halves() and as shape_scales() (zeros, NaN, signs, every largest
    index); the other columns stay as they were."""
    rng = np.random.default_rng(7)
    n = 5 * (1 << 16) + 123  # several blocks, the last one short
    values = rng.normal(scale=3.0, size=(n, 3)).astype(np.float32)
    values[::7] *= np.float32(1e-6)  # subnormal halves
    values[5, 0], values[6, 1], values[7, 2], values[8, 0], values[9] = np.nan, np.inf, -np.inf, 0.0, -0.0
    largest = rng.integers(0, 4, n).astype(np.int8)
    stream = rng.normal(size=(n, packing.SHAPE_VALUES)).astype(np.float32)
    before = stream.copy()
    packing.halves_into(stream[:, 3:6], values, largest)
    packing.halves_into(stream[:, 6:9], values)
    np.testing.assert_array_equal(stream[:, 3:6].view(np.uint32),
                                  packing.shape_scales(values, largest).view(np.uint32))
    np.testing.assert_array_equal(stream[:, 6:9].view(np.uint32), packing.halves(values).view(np.uint32))
    np.testing.assert_array_equal(stream[:, :3], before[:, :3])
    assert (np.signbit(stream[:, 3]) == ((largest & 1) != 0)).all()
    assert (np.signbit(stream[:, 4]) == ((largest & 2) != 0)).all()


@pytest.mark.parametrize("field", ["sh_dc", "scales"])
def test_a_colour_or_size_effect_re_uploads_the_shape_alone(testdata, gpu_ready, field):
    """An effect's frame as items.py hands it: a new key, the untouched arrays named as
    the base's own. A colour (SH DC) or size (scales) change sends the shape texture only
    and draws what a fresh renderer draws."""
    from addon.blender.viewport import ViewportRenderer

    items, centre = two_objects(testdata)
    everything = frozenset(("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest"))
    items = [replace(i, key=(name, 0), base_key=(name, 0), base_fields=everything)
             for name, i in zip("ab", items)]
    cam = camera_for(centre)
    r = ViewportRenderer()
    draw_offscreen(items, cam, renderer=r)
    s = items[0].splats
    changed = replace(items[0], splats=replace(s, **{field: getattr(s, field) * np.float32(0.7)}),
                      key=("a", 0, "effect"), base_fields=everything - {field})
    img, _ = draw_offscreen([changed, items[1]], cam, renderer=r)
    shape = r.gpu.textures["shape"]
    assert r.stats.frame_bytes == shape.width * shape.height * 8, "the shape texture alone (RGBA16F)"
    assert psnr(img, draw_offscreen([changed, items[1]], cam)[0]) == float("inf")


def test_shape_rotation_is_the_readable_smallest_three_bit_for_bit(testdata):
    """The shape stream's rotation part, a block at a time on two threads, against
    halves(smallest_three(q)): a real capture's quaternions, and random ones over several
    blocks with zero, NaN, tied and negative-largest rows."""
    from addon.core.effects.common import BLOCK

    rng = np.random.default_rng(3)
    q = rng.normal(size=(5 * BLOCK + 17, 4)).astype(np.float32)
    q[:3] = 0.0
    q[3, 1] = np.nan
    q[4] = (0.5, -0.5, 0.5, -0.5)   # four equal magnitudes: the first is dropped
    q[5] = (-1.0, 0.0, 0.0, 0.0)
    q[6] = (0.0, 0.0, 0.0, -2.0)
    q[7] = (0.3, 0.3, -0.3, np.inf)
    for rotations in (read(testdata / "guitar.ply").rotations, q):
        three, largest = packing.smallest_three(rotations)
        got_three, got_largest = packing.shape_rotation(rotations)
        np.testing.assert_array_equal(got_largest, largest)
        np.testing.assert_array_equal(got_three.view(np.uint32), packing.halves_fast(three).view(np.uint32))
