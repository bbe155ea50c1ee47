"""Blender 5.3: the splats Blender's own engines draw are Splatline's evaluated splats.

Each test reads what Blender itself evaluates (the object's evaluated geometry in the
depsgraph an engine renders from, or the pixels an engine writes), on real captures with
their axes on the object. Skipped where Blender has no native splats (4.5 .. 5.2)."""
from __future__ import annotations

import numpy as np
import pytest

from testing.effect_ops import add_effect as _effect  # an effect through the real operator

FIELDS = ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")


def _key(owner, path, values):
    for frame, value in values:
        setattr(owner, path, value)
        owner.keyframe_insert(path, frame=frame)


def _three_effect_guitar(bpy, testdata, count=0, name="guitar.ply"):
    """guitar.ply (degree 0) or test64.ply (degree 3) as a user imports it (RDF axes as a
    rotation on the object), with a keyed reveal, a twist and an explode, and a keyed look
    (tint, opacity)."""
    from addon.blender.data.files import import_file

    obj = import_file(bpy.context, str(testdata / name), max_count=count)
    assert obj.rotation_euler[:] != (0.0, 0.0, 0.0)  # the file's axes sit on the object
    _key(_effect(bpy, obj, "REVEAL", edge_width=0.2), "progress", ((1, -0.5), (9, 0.8)))
    _key(_effect(bpy, obj, "TWIST"), "twist", ((1, 0.0), (9, 1.2)))
    _effect(bpy, obj, "EXPLODE", start_frame=3.0, strength=0.5)
    obj.splatline.look.tint = (1.0, 0.8, 0.6)
    _key(obj.splatline.look, "opacity", ((1, 0.6), (9, 1.0)))
    bpy.context.view_layer.update()
    return obj


class Recorder:
    """A frame_change_post handler that runs after Splatline's: what Blender evaluated for
    the object against collect_items' splats (look folded in) of the same depsgraph."""

    def __init__(self, obj):
        self.name, self.seen = obj.name_full, []

    def __call__(self, scene, depsgraph):
        import bpy

        from addon.blender.data.pointcloud import splats_from_pointcloud
        from addon.blender.evaluate.items import collect_items
        from addon.core.fold_look import baked_splats

        obj = bpy.data.objects[self.name]
        got = splats_from_pointcloud(obj.evaluated_get(depsgraph).data)
        item = next(i for i in collect_items(depsgraph) if i.key[0] == self.name)
        self.seen.append((scene.frame_current, depsgraph.mode, got, baked_splats(item)))


@pytest.fixture
def recorder(native_bpy):
    import bpy

    made = []

    def attach(obj):
        made.append(Recorder(obj))
        bpy.app.handlers.frame_change_post.append(made[-1])
        return made[-1]

    yield attach
    for r in made:
        bpy.app.handlers.frame_change_post.remove(r)


def _tiny_workbench(scene, path):
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.render.resolution_x = scene.render.resolution_y = 8
    scene.render.resolution_percentage = 100
    scene.render.filepath = str(path)


def _assert_blender_sees_items(seen, frames):
    assert [f for f, mode, *_ in seen if mode == "RENDER"] == list(frames)
    for frame, mode, got, want in seen:
        assert got.count == want.count, (frame, mode)
        for field in FIELDS:
            np.testing.assert_array_equal(getattr(got, field), getattr(want, field),
                                          err_msg=f"frame {frame} ({mode}): {field}")
    renders = [got for _f, mode, got, _w in seen if mode == "RENDER"]
    pairs = list(zip(renders, renders[1:]))
    for a, b in pairs:  # the stack really moves: no frame equals the next
        assert not np.array_equal(a.positions, b.positions)
    assert any(not np.array_equal(a.opacities, b.opacities) for a, b in pairs)  # and reveals


def test_blender_renders_the_evaluated_splats_f12(native_bpy, testdata, tmp_path, recorder):
    bpy = native_bpy
    obj = _three_effect_guitar(bpy, testdata)
    record = recorder(obj)
    scene = bpy.context.scene
    add_camera(bpy)
    frames = (2, 5, 8)
    for frame in frames:
        scene.frame_set(frame)
        _tiny_workbench(scene, tmp_path / f"still_{frame}.png")
        bpy.ops.render.render(write_still=True)
    _assert_blender_sees_items(record.seen, frames)


@pytest.mark.parametrize("name", ["guitar.ply", "test64.ply"])
def test_blender_renders_the_evaluated_splats_animation(native_bpy, testdata, tmp_path, recorder,
                                                        name):
    bpy = native_bpy
    obj = _three_effect_guitar(bpy, testdata, name=name)
    obj.splatline.look.max_sh_degree = 3 if name == "test64.ply" else 0
    if name == "test64.ply":  # its splats sit where the reveal passes between 0.5 and 1
        _key(obj.splatline.effects[0], "progress", ((1, 0.5), (9, 1.0)))
        # and a lower SH cap from frame 5 on: fewer sh attributes handed off
        _key(obj.splatline.look, "max_sh_degree", ((4, 3), (5, 1)))
    record = recorder(obj)
    _render_animation(bpy, 3, 6, tmp_path / "anim_")
    _assert_blender_sees_items(record.seen, range(3, 7))


def _render_animation(bpy, start, end, path):
    """Blender's own animation render of frames start-end (Workbench, tiny) from a camera."""
    scene = bpy.context.scene
    add_camera(bpy)
    scene.frame_start, scene.frame_end = start, end
    _tiny_workbench(scene, path)
    bpy.ops.render.render(animation=True)


def add_camera(bpy):
    from testing.engine_scene import add_camera as add

    return add(bpy, location=(0.0, -4.0, 0.0))


def test_companion_only_where_splatline_changes_the_splats(native_bpy, testdata):
    from addon.blender.data import evaluated_geometry as geometry
    from addon.blender.evaluate.items import collect_items

    bpy = native_bpy
    bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "test64.ply"))
    obj = bpy.context.view_layer.objects.active
    bpy.context.view_layer.update()
    assert geometry.handoff_modifier(obj) is None  # Blender draws the stored splats
    plain = collect_items(bpy.context.evaluated_depsgraph_get())[0].splats
    _effect(bpy, obj, "EXPLODE", start_frame=1.0)
    bpy.context.scene.frame_set(4)
    other = geometry.companion(obj)
    assert other is not None and other.name not in bpy.context.scene.objects
    depsgraph = bpy.context.evaluated_depsgraph_get()
    assert [o.name for o in depsgraph.objects if o.type == "POINTCLOUD"] == [obj.name]
    items = collect_items(depsgraph)
    assert len(items) == 1  # the companion is not a second splat object
    obj.splatline.effects[0].enabled = False
    bpy.context.view_layer.update()
    again = collect_items(bpy.context.evaluated_depsgraph_get())[0].splats
    for field in FIELDS:  # Splatline reads the stored splats, not the handed-off ones
        np.testing.assert_array_equal(getattr(again, field), getattr(plain, field), err_msg=field)
    got = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    assert len(got.points) == plain.count


def test_cycles_renders_a_revealing_splatline_import(native_bpy, testdata, tmp_path):
    """Cycles ray-traces a Splatline import as splats (not black silhouettes), and the
    reveal's keyed progress shows in its frames."""
    from testing.engine_scene import guitar_scene, read_image

    bpy = native_bpy
    scene, _centre, _size = guitar_scene(bpy, testdata, (1, 2), 48, 32, 20000)
    obj = next(o for o in scene.objects if o.type == "POINTCLOUD")
    _key(_effect(bpy, obj, "REVEAL", edge_width=0.05), "progress", ((1, -0.1), (2, 0.6)))
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 4
    scene.cycles.use_denoising = False
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGBA"
    frames = {}
    for frame in (1, 2):
        scene.frame_set(frame)
        scene.render.filepath = str(tmp_path / f"cycles_{frame}.png")
        bpy.ops.render.render(write_still=True)
        frames[frame] = read_image(tmp_path / f"cycles_{frame}.png").astype(np.float64) / 255
    covered = {f: px[..., 3] > 0.5 for f, px in frames.items()}
    assert covered[2].sum() >= covered[1].sum() + 20  # more of the guitar is revealed
    revealed = frames[2][covered[2]][:, :3]
    assert revealed.mean() > 0.15 and revealed.max() > 0.4  # lit colours, not silhouettes


def test_blender_renders_a_sequence_and_a_hidden_morph_target(native_bpy, tmp_path, recorder):
    """A sequence's frames come from files, not its own data; a morph target whose Look >
    Show is off must not be drawn by Blender either."""
    from addon.blender.data import evaluated_geometry as geometry
    from testing.sequence_files import write_frames

    bpy = native_bpy
    write_frames(tmp_path / "seq", count=3, n=50)
    assert bpy.ops.import_scene.splatline_sequence(directory=str(tmp_path / "seq")) == {"FINISHED"}
    obj = bpy.context.view_layer.objects.active
    record = recorder(obj)
    _render_animation(bpy, 1, 3, tmp_path / "seq_")
    _assert_blender_sees_items(record.seen, (1, 2, 3))
    from addon.blender.data.pointcloud import new_pointcloud_object
    from testing.viewport_scene import blob

    target = new_pointcloud_object("target", blob(30, 1, seed=3, centre=(0, 0, 0), spread=0.2))
    assert len(target.data.points) == 30 and target.data.type == "GAUSSIAN_SPLAT"
    target.splatline.look.visible = False
    bpy.context.view_layer.update()
    shown = target.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    assert geometry.companion(target) is not None and len(shown.points) == 0


def test_a_duplicate_gets_its_own_companion(native_bpy, testdata):
    """Shift+D copies the modifier, which still shows the original's companion: each object
    must end up showing its own evaluated splats."""
    from addon.blender.data import evaluated_geometry as geometry
    from addon.blender.data.pointcloud import splats_from_pointcloud
    from addon.blender.evaluate.items import collect_items
    from addon.core.fold_look import baked_splats

    bpy = native_bpy
    bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "test64.ply"))
    obj = bpy.context.view_layer.objects.active
    _effect(bpy, obj, "EXPLODE", start_frame=1.0)
    bpy.context.scene.frame_set(3)
    with bpy.context.temp_override(active_object=obj, selected_objects=[obj],
                                   selected_editable_objects=[obj]):
        assert bpy.ops.object.duplicate() == {"FINISHED"}
    dup = next(o for o in bpy.context.scene.objects if o.type == "POINTCLOUD" and o is not obj)
    dup.splatline.effects[0].strength = 3.0  # its own splats now differ from the original's
    bpy.context.scene.frame_set(4)
    assert geometry.companion(dup) is not geometry.companion(obj)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    items = {i.key[0]: baked_splats(i) for i in collect_items(depsgraph)}
    for o in (obj, dup):
        got = splats_from_pointcloud(o.evaluated_get(depsgraph).data)
        np.testing.assert_array_equal(got.positions, items[o.name_full].positions, err_msg=o.name)
    assert not np.array_equal(items[obj.name_full].positions, items[dup.name_full].positions)
    obj.name = "renamed"
    bpy.context.scene.frame_set(5)
    assert geometry.companion(obj).get("splatline_evaluated_of") == "renamed"


# Each tweak makes item_for change the splats, so the handoff must not take the object as
# stored: (what to set on obj.splatline, as (group path, property, value)).
TWEAKS = {
    "size": ("look", "size", 1.5), "opacity": ("look", "opacity", 0.5),
    "hidden": ("look", "visible", False), "exposure": ("look", "exposure", 1.0),
    "tint": ("look", "tint", (1.0, 0.5, 0.5)), "saturation": ("look", "saturation", 0.0),
    "sh degree": ("look", "max_sh_degree", 1), "crop": ("look", "use_crop_sphere", True),
}


def test_an_import_is_handed_to_blender_without_reading_its_splats(native_bpy, testdata):
    """A fresh import with the default look: Blender draws its stored splats, and the
    handoff decides so from the settings alone (the base cache stays empty)."""
    from addon.blender.data import evaluated_geometry as geometry
    from addon.blender.data import stored_splats
    from addon.blender.evaluate import items

    bpy = native_bpy
    stored_splats.CACHE.clear()
    bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "guitar.ply"))
    obj = bpy.context.view_layer.objects.active
    bpy.context.scene.frame_set(2)
    bpy.context.view_layer.update()
    assert geometry.handoff_modifier(obj) is None
    assert items.stored_as_is(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()))
    assert not stored_splats.CACHE.entries  # nothing read back


@pytest.mark.parametrize("tweak", sorted(TWEAKS))
def test_a_changed_look_is_never_taken_as_stored(native_bpy, testdata, tweak):
    """On test64 (SH degree 3, so capping the degree cuts bands)."""
    from addon.blender.data import evaluated_geometry as geometry
    from addon.blender.data import stored_splats
    from addon.blender.evaluate import items
    from addon.blender.evaluate.native_handoff import changes_splats

    bpy = native_bpy
    bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "test64.ply"))
    obj = bpy.context.view_layer.objects.active
    group, prop, value = TWEAKS[tweak]
    setattr(getattr(obj.splatline, group), prop, value)
    bpy.context.view_layer.update()
    obj_eval = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    assert not items.stored_as_is(obj_eval)
    if items.shown(obj_eval):
        assert changes_splats(items.item_for(obj_eval))
    assert geometry.handoff_modifier(obj) is not None  # a companion draws the changed splats


def test_an_effect_at_amount_zero_leaves_the_choice_to_the_evaluated_item(native_bpy, testdata):
    """Unsure from settings (an effect on, at amount 0): the item decides, and it is unchanged."""
    from addon.blender.data import evaluated_geometry as geometry
    from addon.blender.data import stored_splats
    from addon.blender.evaluate import items

    bpy = native_bpy
    bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "guitar.ply"))
    obj = bpy.context.view_layer.objects.active
    stored_splats.CACHE.clear()
    effect = obj.splatline.effects.add()  # (the operator would evaluate it at amount 1 first)
    effect.type, effect.amount = "TWIST", 0.0
    bpy.context.view_layer.update()
    obj_eval = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    assert not items.stored_as_is(obj_eval)
    assert stored_splats.CACHE.entries  # read: the settings alone could not tell
    assert geometry.handoff_modifier(obj) is None


def test_blenders_own_import_is_left_to_blender_without_a_read(native_bpy, testdata):
    """wm.ply_import's splat object (Blender's operator, turned as a user would place it):
    with Splatline's default settings the handoff leaves it to Blender unread; a look
    change then gives it a companion."""
    from addon.blender.data import evaluated_geometry as geometry
    from addon.blender.data import stored_splats
    from addon.blender.evaluate import items

    bpy = native_bpy
    stored_splats.CACHE.clear()
    assert bpy.ops.wm.ply_import(filepath=str(testdata / "guitar.ply")) == {"FINISHED"}
    obj = bpy.context.view_layer.objects.active
    assert obj.data.type == "GAUSSIAN_SPLAT"
    obj.rotation_euler = (1.2, 0.3, -0.7)
    bpy.context.scene.frame_set(3)
    bpy.context.view_layer.update()
    assert items.stored_as_is(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()))
    assert geometry.handoff_modifier(obj) is None
    assert not stored_splats.CACHE.entries
    obj.splatline.look.exposure = 1.0
    bpy.context.view_layer.update()
    assert geometry.handoff_modifier(obj) is not None
