"""The background under the splats (Film > Transparent off) is the world's Background node,
as Cycles/EEVEE render it, and world.color only where that node gives no flat colour.
Real bpy, real renders through Blender's pipeline, read back from the EXR."""
from __future__ import annotations

import numpy as np
import pytest

from addon.blender.compat import world_node_tree
from testing.engine_scene import (add_camera, add_splats, flat_splats, read_exr_parts, set_output,
                          setup_render)

W, H = 48, 32
# A colour the tests never expect: where it shows up, the engine read the wrong thing.
DISPLAY_COLOUR = (0.9, 0.02, 0.4)


def _scene(bpy):
    """One splat in the middle of an opaque-film frame; its world has the viewport
    display colour DISPLAY_COLOUR and (Blender 5.0 default) Background -> World Output."""
    add_splats(bpy, "s", flat_splats([(0, 0, 0)], [(0.8, 0.2, 0.1)], scale=0.3))
    add_camera(bpy)
    scene = setup_render(bpy, W, H, transparent=False)
    world = scene.world = bpy.data.worlds.new("World")
    world.color = DISPLAY_COLOUR
    world_node_tree(world)  # 4.5's new world has no tree until it uses nodes
    return scene, world


def _render(bpy, scene, path):
    set_output(scene, "EXR", path)
    bpy.ops.render.render(write_still=True)
    return read_exr_parts(path.with_suffix(".exr"))["ViewLayer.Combined"]


def _assert_background(bpy, scene, tmp_path, want):
    """The opaque render is the transparent one over `want`, and the corners are `want`."""
    opaque = _render(bpy, scene, tmp_path / "opaque")
    scene.render.film_transparent = True
    clear = _render(bpy, scene, tmp_path / "clear")
    scene.render.film_transparent = False
    assert clear[..., 3].max() > 0.95 and clear[0, 0, 3] == 0.0, "a splat in the middle only"
    assert np.all(opaque[..., 3] == 1.0)
    want = np.asarray(want, np.float32)
    np.testing.assert_allclose(opaque[0, 0, :3], want, rtol=1e-6)
    # Premultiplied "over" in scene-linear; float32 rounding of one multiply-add.
    np.testing.assert_allclose(opaque[..., :3], clear[..., :3] + (1.0 - clear[..., 3:]) * want,
                               rtol=1e-6, atol=1e-7)


def test_background_node_colour_times_strength(bpy_empty, tmp_path):
    bpy = bpy_empty
    scene, world = _scene(bpy)
    background = world.node_tree.nodes["Background"]
    colour, strength = (0.3, 0.1, 0.05), 2.5
    background.inputs["Color"].default_value = (*colour, 1.0)
    background.inputs["Strength"].default_value = strength
    _assert_background(bpy, scene, tmp_path, np.float32(colour) * np.float32(strength))


def test_background_through_a_reroute(bpy_empty, tmp_path):
    bpy = bpy_empty
    scene, world = _scene(bpy)
    tree = world.node_tree
    background, output = tree.nodes["Background"], tree.nodes["World Output"]
    background.inputs["Color"].default_value = (0.2, 0.4, 0.1, 1.0)
    reroute = tree.nodes.new("NodeReroute")
    tree.links.new(background.outputs["Background"], reroute.inputs[0])
    tree.links.new(reroute.outputs[0], output.inputs["Surface"])
    _assert_background(bpy, scene, tmp_path, (0.2, 0.4, 0.1))


def test_keyframed_background_is_taken_at_the_rendered_frame(bpy_empty, tmp_path):
    bpy = bpy_empty
    scene, world = _scene(bpy)
    background = world.node_tree.nodes["Background"]
    colour, strength = background.inputs["Color"], background.inputs["Strength"]
    keys = {1: ((0.6, 0.3, 0.1), 1.0), 3: ((0.05, 0.2, 0.7), 2.0)}
    for frame, (c, s) in keys.items():
        colour.default_value = (*c, 1.0)
        strength.default_value = s
        colour.keyframe_insert("default_value", frame=frame)
        strength.keyframe_insert("default_value", frame=frame)
    # The original node holds frame 2's values; each rendered frame needs its own.
    scene.frame_set(2)
    scene.frame_start, scene.frame_end = 1, 3
    set_output(scene, "EXR", tmp_path / "anim_####")
    bpy.ops.render.render(animation=True)
    got = {f: read_exr_parts(tmp_path / f"anim_{f:04d}.exr")["ViewLayer.Combined"][0, 0]
           for f in (1, 2, 3)}
    for frame, (c, s) in keys.items():
        np.testing.assert_allclose(got[frame], [*(np.float32(c) * np.float32(s)), 1.0], rtol=1e-6)
    # Frame 2 is interpolated: strictly between the keys in every channel.
    lo, hi = np.minimum(got[1], got[3])[:3], np.maximum(got[1], got[3])[:3]
    assert np.all((got[2][:3] > lo) & (got[2][:3] < hi))


def _remove_background(tree):
    tree.nodes.remove(tree.nodes["Background"])


def _emission_instead(tree):
    _remove_background(tree)
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (0.1, 0.8, 0.1, 1.0)
    tree.links.new(emission.outputs[0], tree.nodes["World Output"].inputs["Surface"])


def _colour_from_texture(tree):
    texture = tree.nodes.new("ShaderNodeTexGradient")
    tree.links.new(texture.outputs["Color"], tree.nodes["Background"].inputs["Color"])


def _strength_from_node(tree):
    value = tree.nodes.new("ShaderNodeValue")
    value.outputs[0].default_value = 3.0
    tree.links.new(value.outputs[0], tree.nodes["Background"].inputs["Strength"])


def _muted_link(tree):
    tree.nodes["World Output"].inputs["Surface"].links[0].is_muted = True


@pytest.mark.parametrize("change", [_remove_background, _emission_instead, _colour_from_texture,
                                   _strength_from_node, _muted_link],
                         ids=lambda f: f.__name__.strip("_"))
def test_world_color_without_a_flat_background_node(bpy_empty, tmp_path, change):
    """No Background node at the output, or one this engine cannot evaluate: world.color."""
    bpy = bpy_empty
    scene, world = _scene(bpy)
    # A distinct node colour, so that reading the node by mistake shows.
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.3, 0.3, 1.0)
    change(world.node_tree)
    _assert_background(bpy, scene, tmp_path, DISPLAY_COLOUR)


def test_no_world_is_black(bpy_empty, tmp_path):
    bpy = bpy_empty
    scene, _ = _scene(bpy)
    scene.world = None
    _assert_background(bpy, scene, tmp_path, (0.0, 0.0, 0.0))
