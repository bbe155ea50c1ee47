"""Splats and meshes in one final frame, through Blender's own render pipeline.

The scene is testing/holdout_scenes.guitar_scene built from real primitives
(mesh_layer_scene.py): guitar.ply, a cube in front of part of it, one behind, a tilted
plane through the middle. Nothing is set up by hand: the Splatline engine with meshes in
the scene is enough (render/mesh_layer.py makes the mesh scene and the compositor).

What each test holds, and what removing a feature breaks:
- the splat layer (ViewLayer.Combined: the engine's own pass) matches the float64 reference
  with the scene's holdout at >= 45 dB, and not the reference without it (holdout);
- the final frame (the compositor's, Composite.Combined) shows each cube where the
  reference's held-out splats leave the pixel (nearly) empty, and is the splat layer over
  the mesh layer, C = C_s + (1 - a_s) C_m, A = a_s + (1 - a_s) a_m (mesh layer);
- its Depth is core.holdout.combine_depth of the splats' and the surfaces' (Z pass);
- Meshes: Hide Splats Only / Ignored, and switching engines, take the set-up back off.
"""
from __future__ import annotations

import numpy as np
import pytest

from testing.engine_paths_scene import to_display
from testing.engine_scene import read_exr_parts, set_output
from testing.mesh_layer_scene import build
from testing.viewport_scene import psnr

W, H = 96, 64
COUNT = 20000          # the guitar's most important splats (the reference stays quick)
MIN_PSNR = 45.0


def render_still(bpy, scene, path):
    set_output(scene, "EXR", path)
    bpy.ops.render.render(write_still=True)
    return read_exr_parts(path)


def reference(bpy, scene, holdout):
    """The float64 reference of the evaluated scene under the camera Blender renders."""
    from addon.blender.evaluate.items import collect_items
    from addon.blender.render.camera import camera_from_blender
    from addon.core import reference as core_reference

    depsgraph = bpy.context.evaluated_depsgraph_get()
    camera = camera_from_blender(scene, scene.camera, depsgraph)
    options = scene.splatline.render.options()
    if holdout is not None:
        import dataclasses

        options = dataclasses.replace(options, holdout=holdout)
    return core_reference.render(collect_items(depsgraph), camera, options), camera


@pytest.fixture
def guitar(bpy_empty, testdata, tmp_path):
    """(bpy, scene, HoldoutScene, mesh objects, EXR parts of one still) with the Z pass on."""
    bpy = bpy_empty
    hs, objects, _ = build(bpy, testdata, W, H, COUNT)
    scene = bpy.context.scene
    parts = render_still(bpy, scene, tmp_path / "still.exr")
    return bpy, scene, hs, objects, parts


def test_set_up_without_asking(guitar):
    from addon.blender.compat import active_compositor
    from addon.blender.data.sources import is_splat_object
    from addon.blender.render import mesh_compositor, mesh_layer

    bpy, scene, _hs, objects, parts = guitar
    companion = scene.splatline.render.mesh_scene
    assert companion is not None and mesh_layer.attached(scene)
    assert companion.render.engine == "BLENDER_WORKBENCH"  # the default Mesh Engine
    assert set(companion.objects) == set(objects.values()), "the surfaces, no splats, no camera"
    assert not any(is_splat_object(o) for o in companion.objects)
    assert companion.camera == scene.camera and companion.world == scene.world
    assert active_compositor(scene).get(mesh_compositor.OWNED)
    assert {"Composite.Combined", "ViewLayer.Combined", "ViewLayer.Depth"} <= parts.keys()


def test_splat_layer_matches_the_reference_with_the_holdout(guitar):
    bpy, scene, hs, _objects, parts = guitar
    held, _camera = reference(bpy, scene, hs.holdout)
    plain, _ = reference(bpy, scene, None)
    splat = to_display(parts["ViewLayer.Combined"])
    got, without = psnr(splat, held.rgba), psnr(splat, plain.rgba)
    assert got >= MIN_PSNR, f"splat layer vs the held-out reference: {got:.1f} dB"
    assert without < 30.0, f"the meshes hide part of the guitar ({without:.1f} dB without them)"
    print(f"splat layer vs reference with holdout: {got:.1f} dB (without: {without:.1f} dB)")


def _mesh_pixels(hs, camera):
    from addon.core.holdout import Holdout, holdout_depth

    return {name: np.isfinite(holdout_depth(Holdout(t), camera)) for name, t in hs.triangles.items()}


def _inside(mask):
    """The pixels of mask whose 8 neighbours are in it too (edges are antialiased)."""
    m = np.pad(mask, 1)
    out = mask.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            out &= m[1 + dy:m.shape[0] - 1 + dy, 1 + dx:m.shape[1] - 1 + dx]
    return out


def test_final_frame_shows_the_cubes_where_the_splats_leave_them(guitar):
    bpy, scene, hs, _objects, parts = guitar
    held, camera = reference(bpy, scene, hs.holdout)
    seen = _mesh_pixels(hs, camera)
    final, splat = parts["Composite.Combined"], parts["ViewLayer.Combined"]
    empty = held.rgba[..., 3] < 0.02
    opaque = held.rgba[..., 3] > 0.99
    front = _inside(seen["front_cube"]) & empty
    back = _inside(seen["back_cube"] & ~seen["front_cube"] & ~seen["plane"]) & empty
    assert front.sum() > 40 and back.sum() > 20
    for mask, (hue, others) in ((front, (1, (0, 2))), (back, (2, (0, 1)))):
        rgb = final[mask][:, :3]
        assert (final[mask][:, 3] > 0.997).all(), "an opaque cube (Workbench: 0.998)"
        assert (rgb[:, hue] > 1.5 * rgb[:, others].max(axis=1)).mean() > 0.95, "its colour"
        assert (splat[mask][:, 3] < 0.05).all(), "no splats there in the splat layer"
    # Behind the opaque guitar, the back cube is hidden: the frame is the splats' there.
    hidden = _inside(seen["back_cube"] & ~seen["front_cube"] & ~seen["plane"]) & opaque
    assert hidden.sum() > 10
    np.testing.assert_allclose(final[hidden], splat[hidden], atol=2e-2)


def test_final_frame_is_the_splat_layer_over_the_mesh_layer(guitar, tmp_path):
    bpy, scene, _hs, _objects, parts = guitar
    companion = scene.splatline.render.mesh_scene
    for name in ("resolution_x", "resolution_y", "resolution_percentage"):
        setattr(companion.render, name, getattr(scene.render, name))
    set_output(companion, "EXR", tmp_path / "meshes.exr")
    bpy.ops.render.render(write_still=True, scene=companion.name)
    meshes = next(v for k, v in read_exr_parts(tmp_path / "meshes.exr").items()
                  if k.endswith("Combined"))
    splat, final = parts["ViewLayer.Combined"], parts["Composite.Combined"]
    a = splat[..., 3:]
    assert meshes[..., 3].max() > 0.99 and meshes[..., 3].min() == 0.0
    np.testing.assert_allclose(final, splat + (1.0 - a) * meshes, atol=2e-3)
    np.testing.assert_allclose(final[..., 3], a[..., 0] + (1 - a[..., 0]) * meshes[..., 3], atol=2e-3)


def test_depth_is_the_nearer_of_splats_and_surfaces(guitar):
    from addon.blender.render.film import BACKGROUND_DEPTH
    from addon.core.holdout import combine_depth, holdout_depth

    bpy, scene, hs, _objects, parts = guitar
    held, camera = reference(bpy, scene, hs.holdout)
    want = combine_depth(held.depth, held.rgba[..., 3], holdout_depth(hs.holdout, camera))
    want = np.where(np.isfinite(want), want, BACKGROUND_DEPTH)
    got = parts["ViewLayer.Depth"][..., 0]
    surface = np.isfinite(holdout_depth(hs.holdout, camera))
    assert (got[surface] < BACKGROUND_DEPTH).all(), "every surface pixel has a depth"
    clear = np.abs(held.rgba[..., 3] - 0.5) > 0.02  # away from the splats' 0.5 alpha cut
    np.testing.assert_allclose(got[clear], want[clear], rtol=5e-4)  # GL's float32 depth
    # where the front cube hides the guitar, the depth is the cube's, not the guitar's
    front = np.isfinite(holdout_depth(type(hs.holdout)(hs.triangles["front_cube"]), camera))
    assert (got[front & clear] < np.where(np.isfinite(held.depth), held.depth, 1e9)[front & clear] + 1e-6).all()


def test_hide_splats_only_and_ignored(guitar, tmp_path):
    from addon.blender.compat import active_compositor
    from addon.blender.render import mesh_layer

    bpy, scene, hs, _objects, parts = guitar
    settings = scene.splatline.render
    settings.meshes = "HOLDOUT"  # the setting's update takes the set-up off
    assert not mesh_layer.attached(scene) and active_compositor(scene) is None
    holdout = render_still(bpy, scene, tmp_path / "holdout.exr")
    assert holdout.keys() == {"ViewLayer.Combined", "ViewLayer.Depth"}
    np.testing.assert_array_equal(holdout["ViewLayer.Combined"], parts["ViewLayer.Combined"])
    settings.meshes = "IGNORE"
    ignored = render_still(bpy, scene, tmp_path / "ignored.exr")
    plain, _ = reference(bpy, scene, None)
    assert psnr(to_display(ignored["ViewLayer.Combined"]), plain.rgba) >= MIN_PSNR
    settings.meshes = "DRAW"
    assert mesh_layer.attached(scene)


def test_other_engines_get_no_mesh_layer_and_user_trees_are_kept(guitar):
    from addon.blender import compat
    from addon.blender.render import mesh_compositor, mesh_layer

    bpy, scene, *_ = guitar
    scene.render.engine = "BLENDER_WORKBENCH"
    bpy.context.view_layer.update()
    assert compat.active_compositor(scene) is None, "Splatline's own compositor is gone"
    # A compositor of the user's own (Render Layers -> Glare -> output) keeps its nodes:
    # the Alpha Over goes between the Render Layers node and what it fed, and comes out again.
    tree, output = compat.new_compositor(scene, "Mine")
    layers = tree.nodes.new("CompositorNodeRLayers")
    glare = tree.nodes.new("CompositorNodeGlare")
    tree.links.new(layers.outputs["Image"], glare.inputs[0])
    tree.links.new(glare.outputs[0], output)
    scene.render.engine = "SPLATLINE"
    bpy.context.view_layer.update()
    assert mesh_layer.attached(scene) and not tree.get(mesh_compositor.OWNED)
    over = next(n for n in tree.nodes if n.name.startswith(mesh_compositor.MESH_OVER))
    assert over.outputs[0].links[0].to_node == glare
    scene.render.engine = "CYCLES"
    bpy.context.view_layer.update()
    assert compat.active_compositor(scene) == tree and not mesh_layer.attached(scene)
    assert glare.inputs[0].links[0].from_node == layers
    assert {n.bl_idname for n in tree.nodes} >= {"CompositorNodeRLayers", "CompositorNodeGlare"}
    assert not any(n.name.startswith("Splatline") for n in tree.nodes)


def test_render_panel_shows_the_mesh_settings(guitar):
    """Render tab > Splatline: Meshes, Mesh Engine and the (read-only) Mesh Scene."""
    from types import SimpleNamespace

    from addon.blender.ui import render_panel
    from testing.ui_layout import RecordingLayout, check_names_exist as _check_names_exist

    bpy, scene, *_ = guitar
    layout = RecordingLayout()
    context = SimpleNamespace(scene=scene, engine=render_panel.ENGINE)
    bpy.types.SPLATLINE_PT_render.draw(SimpleNamespace(layout=layout), context)
    _check_names_exist(bpy, layout.record)
    props = [what[1] for kind, what, _ in layout.record if kind == "prop"]
    assert {"meshes", "mesh_engine", "mesh_scene"} <= set(props)


def test_world_is_drawn_behind_meshes_and_splats(guitar, tmp_path):
    """Film > Transparent off: the mesh engine draws the world behind everything; the splat
    layer stays transparent (else the world would cover the meshes)."""
    from addon.blender.compat import world_node_tree

    bpy, scene, hs, _objects, _parts = guitar
    grey = (0.2, 0.3, 0.4)
    scene.world = bpy.data.worlds.new("grey")
    scene.world.color = grey  # Workbench draws the world's viewport colour
    world_node_tree(scene.world).nodes["Background"].inputs["Color"].default_value = (*grey, 1.0)
    scene.render.film_transparent = False
    parts = render_still(bpy, scene, tmp_path / "world.exr")
    final, splat = parts["Composite.Combined"], parts["ViewLayer.Combined"]
    assert (final[..., 3] > 0.997).all()  # Workbench's 8 AA samples sum to 0.998
    held, camera = reference(bpy, scene, hs.holdout)
    from addon.core.holdout import holdout_depth

    # no splat and no surface there, nor at the neighbours (antialiased mesh edges)
    nothing = _inside(~np.isfinite(holdout_depth(hs.holdout, camera))) & (held.rgba[..., 3] == 0)
    nothing &= splat[..., 3] == 0.0  # the splat layer is transparent there (no world in it)
    assert nothing.sum() > 2000
    np.testing.assert_allclose(final[nothing][:, :3], np.broadcast_to(grey, (nothing.sum(), 3)), atol=2e-3)


def test_cli_render_of_the_scene_matches_the_reference(guitar, tmp_path):
    """`python -m addon render SCENE.blend`: the same splat layer (>= 45 dB against the
    reference with the holdout) and the same final frame as bpy.ops.render.render."""
    from testing.cli_runs import render_command as _cli, run_all as _run_all

    bpy, scene, hs, _objects, parts = guitar
    blend = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    frame = scene.frame_current
    _run_all([_cli(blend, "--out", tmp_path / "cli", "--format", "EXR", "--frames", f"{frame}-{frame}")])
    (name,) = [n for n in (tmp_path / "cli").iterdir() if n.suffix == ".exr"]
    cli = read_exr_parts(name)
    held, _camera = reference(bpy, scene, hs.holdout)
    got = psnr(to_display(cli["ViewLayer.Combined"]), held.rgba)
    assert got >= MIN_PSNR, f"CLI splat layer vs the held-out reference: {got:.1f} dB"
    np.testing.assert_allclose(cli["Composite.Combined"], parts["Composite.Combined"], atol=1e-3)
