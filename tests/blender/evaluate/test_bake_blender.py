"""Bake and export of evaluated splats through real bpy, and the must-show round trip:
a folder of frames written by the bake re-imports as a sequence that plays back the same
data per frame."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.formats import read, write
from testing.synth import random_splats

FRAMES = (1, 2, 3, 4)


def animated_source(bpy, tmp_path):
    """A capture whose evaluated splats change every frame: a Geometry Nodes Set Position
    with a keyframed offset (a real depsgraph evaluation, no effect code needed)."""
    from addon.blender.data.files import import_file

    path = tmp_path / "capture.ply"
    write(path, random_splats(60, degree=2, seed=7))
    obj = import_file(bpy.context, path)
    tree = bpy.data.node_groups.new("Move", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    gin, gout = tree.nodes.new("NodeGroupInput"), tree.nodes.new("NodeGroupOutput")
    move = tree.nodes.new("GeometryNodeSetPosition")
    tree.links.new(gin.outputs[0], move.inputs["Geometry"])
    tree.links.new(move.outputs[0], gout.inputs[0])
    offset = move.inputs["Offset"]
    for frame, value in ((1, (0.0, 0.0, 0.0)), (4, (3.0, -1.5, 0.75))):
        offset.default_value = value
        offset.keyframe_insert("default_value", frame=frame)
    obj.modifiers.new("Move", "NODES").node_group = tree
    return obj, read(path)


def item_of(bpy, obj, frame):
    from addon.blender.evaluate.items import collect_items

    bpy.context.scene.frame_set(frame)
    hits = [i for i in collect_items(bpy.context.evaluated_depsgraph_get()) if i.key[0] == obj.name]
    assert len(hits) == 1
    return hits[0]


def bake(bpy, obj, directory, start, end):
    bpy.context.view_layer.objects.active = obj
    return bpy.ops.splatline.bake_sequence(directory=str(directory), frame_start=start, frame_end=end)


def test_bake_round_trip_plays_back_per_frame(bpy_empty, tmp_path):
    """Must-show: bake N frames, re-import the folder as a sequence, same data per frame."""
    from addon.blender.data.sequences import import_sequence

    bpy = bpy_empty
    src, capture = animated_source(bpy, tmp_path)
    evaluated = {f: item_of(bpy, src, f).splats for f in FRAMES}
    # the animation really moves the splats, so a frame mix-up cannot pass unnoticed
    assert len({evaluated[f].positions.tobytes() for f in FRAMES}) == len(FRAMES)
    np.testing.assert_array_equal(evaluated[1].positions, capture.positions)

    bpy.context.scene.frame_set(2)
    assert bake(bpy, src, tmp_path / "baked", 1, 4) == {"FINISHED"}
    assert bpy.context.scene.frame_current == 2  # the bake restores the frame
    files = sorted(p.name for p in (tmp_path / "baked").iterdir())
    assert files == [f"frame_{f:04d}.ply" for f in FRAMES]

    seq = import_sequence(bpy.context, tmp_path / "baked")
    assert seq.splatline.sequence.frame_count == 4
    for f in (1, 2, 3, 4, 2):
        got = item_of(bpy, seq, f).splats
        want = evaluated[f]
        for name in ("positions", "scales", "rotations", "sh_dc", "sh_rest"):
            # PLY stores float32 raw, scales as a float64 log that the reader inverts exactly
            np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
        # opacity goes through logit/sigmoid (float64 both ways): at most one float32 step
        step = np.spacing(want.opacities)
        assert np.all(np.abs(got.opacities - want.opacities) <= step)
        assert np.array_equal(got.positions, want.positions) and not any(
            np.array_equal(got.positions, evaluated[g].positions) for g in FRAMES if g != f)
    # the baked object keeps the source's axis convention on its transform
    np.testing.assert_allclose(np.array(seq.matrix_world), np.array(src.matrix_world), atol=1e-12)


def test_export_evaluated_ply_and_splat(bpy_empty, tmp_path):
    from addon.blender.evaluate.bake import export_evaluated

    bpy = bpy_empty
    src, _ = animated_source(bpy, tmp_path)
    want = item_of(bpy, src, 3).splats
    depsgraph = bpy.context.evaluated_depsgraph_get()
    export_evaluated(src, depsgraph, tmp_path / "f3.ply")
    export_evaluated(src, depsgraph, tmp_path / "f3.splat")
    ply, splat = read(tmp_path / "f3.ply"), read(tmp_path / "f3.splat")
    np.testing.assert_array_equal(ply.positions, want.positions)
    np.testing.assert_array_equal(ply.sh_rest, want.sh_rest)
    assert splat.count == want.count and splat.sh_degree == 0
    # .splat stores float32 positions, so they survive even there (order may be by importance)
    assert set(map(tuple, splat.positions)) == set(map(tuple, want.positions))


def test_bake_errors_leave_no_files(bpy_empty, tmp_path):
    bpy = bpy_empty
    src, _ = animated_source(bpy, tmp_path)
    with pytest.raises(RuntimeError, match="empty frame range"):
        bake(bpy, src, tmp_path / "none", 5, 2)
    assert not (tmp_path / "none").exists()
    src.hide_viewport = True  # not in the evaluated scene: nothing to bake
    with pytest.raises(RuntimeError, match="not a visible splat object"):
        bake(bpy, src, tmp_path / "hidden", 1, 2)
    assert not any((tmp_path / "hidden").glob("*.ply"))


def _keyed_look(obj):
    look = obj.splatline.look
    for frame, (size, opacity, exposure, hue) in ((1, (1.0, 1.0, 0.0, 0.0)), (3, (1.6, 0.4, 0.7, 0.9))):
        look.size, look.opacity, look.exposure, look.hue = size, opacity, exposure, hue
        for name in ("size", "opacity", "exposure", "hue"):
            look.keyframe_insert(name, frame=frame)
    look.tint, look.saturation, look.max_sh_degree = (0.9, 1.0, 0.7), 0.6, 1


def test_bake_folds_the_look_and_renders_the_same(bpy_empty, tmp_path):
    """Keyframed look (size, opacity, tint, exposure, saturation, hue, SH cap) is baked into
    the data: the re-imported sequence, with no look of its own, renders like the source."""
    from addon.blender.data.sequences import import_sequence
    from addon.core import reference
    from addon.core.fold_look import baked_splats
    from addon.core.camera import look_at, simple_camera

    bpy = bpy_empty
    src, _ = animated_source(bpy, tmp_path)
    _keyed_look(src)
    sources = {f: item_of(bpy, src, f) for f in (1, 2, 3)}
    assert sources[3].splat_scale == pytest.approx(1.6) and sources[1].splat_scale == 1.0
    assert bake(bpy, src, tmp_path / "look", 1, 3) == {"FINISHED"}
    seq = import_sequence(bpy.context, tmp_path / "look")
    camera = simple_camera(40, 40, 70.0, look_at((0.0, -14.0, 2.0), (0.0, 0.0, 0.0)))
    for f in (1, 2, 3):
        got, source = item_of(bpy, seq, f), sources[f]
        want = baked_splats(source)
        assert got.splats.sh_degree == 1
        for name in ("positions", "rotations", "sh_dc", "sh_rest"):
            np.testing.assert_array_equal(getattr(got.splats, name), getattr(want, name), err_msg=name)
        # PLY keeps log(scale) in float32: a scale not read from a PLY (here multiplied by
        # the look's size) comes back within |ln s| + 1 float32 steps of relative error
        bound = (np.abs(np.log(want.scales.astype(np.float64))) + 1.0) * 2.0 ** -24 * want.scales
        assert np.all(np.abs(got.splats.scales - want.scales) <= bound)
        # likewise logit(opacity) in float32: one logit step times d(sigmoid) = o(1 - o),
        # plus the final float32 rounding
        o = want.opacities.astype(np.float64)
        bound = o * (1 - o) * np.abs(np.log(o / (1 - o))) * 2.0 ** -23 + np.spacing(want.opacities)
        assert np.all(np.abs(got.splats.opacities - want.opacities) <= bound)
        a = reference.render([source], camera).rgba
        b = reference.render([got], camera).rgba
        assert a[..., 3].max() > 0.5  # the capture is in view
        # dc'/rest' are stored in float32 (relative 6e-8, |dc'| up to ~10, 4 bands summed);
        # scale products round once in float32: well under 1e-4 of a unit colour
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-4)


def test_sequence_with_an_effect_bakes_and_replays(bpy_empty, tmp_path):
    """Effects act on each sequence frame, and a bake of that re-imports frame for frame."""
    from addon.blender.data.sequences import import_sequence

    bpy = bpy_empty
    raw = []
    (tmp_path / "in").mkdir()
    for f in FRAMES:
        write(tmp_path / "in" / f"shot_{f:03d}.ply", random_splats(50, degree=1, seed=30 + f))
        raw.append(read(tmp_path / "in" / f"shot_{f:03d}.ply"))
    src = import_sequence(bpy.context, tmp_path / "in")
    effect = src.splatline.effects.add()
    effect.type, effect.amplitude, effect.frequency = "DISPLACE", 0.3, 2.0
    evaluated = {f: item_of(bpy, src, f).splats for f in FRAMES}
    for f in FRAMES:  # the displacement really moved the frame's splats
        assert not np.allclose(evaluated[f].positions, raw[f - 1].positions, atol=1e-3)
    assert bake(bpy, src, tmp_path / "out", FRAMES[0], FRAMES[-1]) == {"FINISHED"}
    baked = import_sequence(bpy.context, tmp_path / "out")
    for f in reversed(FRAMES):
        got = item_of(bpy, baked, f).splats
        for name in ("positions", "rotations", "sh_dc", "sh_rest"):
            np.testing.assert_array_equal(getattr(got, name), getattr(evaluated[f], name), err_msg=name)


def test_export_operator_writes_ply_or_splat(bpy_empty, tmp_path):
    bpy = bpy_empty
    src, _ = animated_source(bpy, tmp_path)
    want = item_of(bpy, src, 4).splats
    bpy.context.view_layer.objects.active = src
    assert bpy.ops.export_scene.splatline_evaluated(filepath=str(tmp_path / "e.splat")) == {"FINISHED"}
    assert bpy.ops.export_scene.splatline_evaluated(filepath=str(tmp_path / "e")) == {"FINISHED"}
    np.testing.assert_array_equal(read(tmp_path / "e.ply").positions, want.positions)
    assert read(tmp_path / "e.splat").count == want.count


def test_real_spz_capture_bakes_to_ply_and_renders_the_same(bpy_empty, tmp_path, testdata):
    """A real SPZ capture (y-up convention, degree 3) played as a 2-frame sequence, baked to
    PLY (y-down convention: the export re-expresses the data) and re-imported: the new
    object's transform carries the other convention, and the picture is the same."""
    import shutil

    from addon.blender.data.sequences import import_sequence
    from addon.core import reference
    from addon.core.camera import look_at, simple_camera

    bpy = bpy_empty
    (tmp_path / "spz").mkdir()
    for f in (1, 2):
        shutil.copyfile(testdata / "test64.spz", tmp_path / "spz" / f"t_{f}.spz")
    src = import_sequence(bpy.context, tmp_path / "spz")
    src.splatline.look.exposure = 0.5
    assert bake(bpy, src, tmp_path / "ply", 1, 2) == {"FINISHED"}
    baked = import_sequence(bpy.context, tmp_path / "ply")
    assert not np.allclose(np.array(baked.matrix_world), np.array(src.matrix_world))
    a_item, b_item = item_of(bpy, src, 2), item_of(bpy, baked, 2)
    centre = a_item.world[:3, :3] @ a_item.splats.positions.mean(axis=0) + a_item.world[:3, 3]
    extent = float(np.abs(a_item.splats.positions - a_item.splats.positions.mean(axis=0)).max())
    camera = simple_camera(32, 32, 60.0, look_at(centre + np.array([0.0, -4.0 * extent, 0.5 * extent]), centre))
    a = reference.render([a_item], camera).rgba
    b = reference.render([b_item], camera).rgba
    assert a[..., 3].max() > 0.2
    # SH rotated by the axis change and the colour fold are float32 (a few 1e-7 relative on
    # coefficients of magnitude ~1): 1e-4 of a unit colour is far above that, far below a u8 step
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-4)
