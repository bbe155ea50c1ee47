"""Look > Lighting in the viewport (issue 43): the preprocess pass lights the splats in its
shader (shaders/viewport_lighting.glsl), so a light dragged uploads the object table alone.
Drawn by Blender's GPU, real captures imported by the operator (their axes turned on the
object, one scaled unevenly, one graded by a deferred effect) under each kind of light
match the float64 reference drawing the engine's CPU-lit splats; the viewport casts no
shadows. Solid shading shows the capture unlit (real bpy)."""
from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from addon.core import reference
from testing.lit_scene import add_light, grey_world
from testing.viewport_scene import draw_offscreen, overlay_drawn, psnr


def _imported(bpy, path):
    assert bpy.ops.import_scene.splatline_gaussians(filepath=str(path)) == {"FINISHED"}
    return overlay_drawn(bpy.context.active_object)


def _aim(obj, at) -> None:
    from mathutils import Vector

    obj.rotation_euler = (Vector(at) - obj.location).to_track_quat("-Z", "Y").to_euler()


def _scene(bpy, testdata):
    """guitar.ply (degree 0) graded by a deferred effect and scaled unevenly, and test64.ply
    (degree 3) beside it; a spot, a point, a sun and an area light, none casting shadows; a
    perspective camera; a grey World."""
    from mathutils import Vector

    guitar = _imported(bpy, testdata / "guitar.ply")
    guitar.scale = (1.0, 1.4, 0.8)  # normals go by the inverse transpose
    with bpy.context.temp_override(object=guitar):
        assert bpy.ops.splatline.effect_add(type="GRADE") == {"FINISHED"}
    small = _imported(bpy, testdata / "test64.ply")
    for obj in (guitar, small):
        obj.splatline.look.lighting = 1.0
    bpy.context.view_layer.update()
    centre = Vector(np.mean([v[:] for v in guitar.bound_box], 0))
    centre = guitar.matrix_world @ centre
    small.location = centre + Vector((0.3, -0.2, 0.1))
    lights = []
    for kind, offset in (("SPOT", (0.6, -0.8, 1.2)), ("POINT", (-1.0, -0.4, 0.6)),
                         ("SUN", (0.0, 0.0, 1.0)), ("AREA", (0.2, -1.2, -0.3))):
        light = add_light(bpy, kind, location=centre + Vector(offset))
        light.data.use_shadow = False
        _aim(light, centre + Vector((0.1, 0.0, 0.0)))
        lights.append(light)
    lights[2].rotation_euler = (0.5, 0.3, 0.0)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    bpy.context.scene.collection.objects.link(camera)
    camera.location = centre + Vector((0.4, -2.2, 0.9))
    _aim(camera, centre)
    scene = bpy.context.scene
    scene.camera = camera
    scene.render.resolution_x, scene.render.resolution_y = 96, 72
    scene.render.resolution_percentage = 100
    grey_world(bpy, scene, 0.2)
    bpy.context.view_layer.update()
    return guitar, lights


def _viewport_against_engine(bpy, viewport, shown=None):
    """(the viewport's items, PSNR of its lit draw against the reference drawing the
    engine's lit splats); shown: an object that must cover some of the frame. The
    viewport sorts by 32-bit keys here (Sort Precision): lit splats five times brighter
    than the capture made 16-bit keys' order slips show (56 dB with the negative light)."""
    from addon.blender.evaluate.items import collect_items
    from addon.blender.evaluate.lighting import lighting_for
    from addon.blender.render.camera import camera_from_blender
    from addon.blender.viewport import DrawSettings, ItemDisplay

    depsgraph = bpy.context.evaluated_depsgraph_get()
    if viewport is None:  # Rendered shading with the Splatline engine: its view_draw's items
        from addon.blender.render import engine

        items, displays = engine._viewport_items(depsgraph), None
    else:
        items, displays = viewport.collect(bpy.context)
    camera = camera_from_blender(bpy.context.scene, bpy.context.scene.camera)
    settings = DrawSettings(lighting=lighting_for(items, depsgraph))
    displays = [replace(d, key_bits=32) for d in displays or [ItemDisplay()] * len(items)]
    drawn, drew = draw_offscreen(items, camera, displays, settings)
    drew.close()
    engine_items = collect_items(depsgraph)
    want = reference.render(engine_items, camera).rgba
    if shown is not None:
        alone = [i for i in engine_items if i.key[0] == shown.name_full]
        assert (reference.render(alone, camera).rgba[..., 3] > 0.1).mean() > 0.02
    return items, psnr(drawn, want)


@pytest.mark.parametrize("drawer", ["overlay", "rendered"])
def test_the_viewport_lights_in_its_shader_as_the_engine_lights_its_splats(gpu_ready, bpy_empty, testdata, drawer):
    """drawer: the draw handler's items (Material Preview), or the engine's view_draw's
    (Rendered shading with Splatline, the one that lights natively drawn splats on 5.3)."""
    from addon.blender.viewport.scene_items import SceneItems

    bpy = bpy_empty
    guitar, lights = _scene(bpy, testdata)
    viewport = SceneItems() if drawer == "overlay" else None
    items, value = _viewport_against_engine(bpy, viewport)
    print(f"lit captures, viewport (GPU shader) against the float64 reference: {value:.1f} dB")
    assert [i.lighting for i in items] == [1.0, 1.0]
    assert value >= 60.0

    lights[0].location.x -= 0.5  # a light dragged: the same splats, lit anew on the GPU
    lights[1].data.energy *= -3.0  # a negative light (Blender allows it): it darkens
    bpy.context.view_layer.update()
    moved, value = _viewport_against_engine(bpy, viewport)
    print(f"after a light moved: {value:.1f} dB")
    # nothing to upload but the table: the same data, under the same keys
    assert all(a.key == b.key and a.base_key == b.base_key for a, b in zip(moved, items))
    if drawer == "overlay":
        assert all(a.splats is b.splats for a, b in zip(moved, items))
    assert value >= 60.0

    guitar.splatline.look.lighting = 0.5  # halfway: the colour blended with the capture's
    bpy.context.view_layer.update()
    half, value = _viewport_against_engine(bpy, viewport)
    print(f"Lighting 0.5: {value:.1f} dB")
    assert sorted(i.lighting for i in half) == [0.5, 1.0]
    assert value >= 60.0


def test_lighting_0_draws_what_an_unlit_viewport_draws(gpu_ready, bpy_empty, testdata):
    """The light table in the object texture moves the effects' rows; an object at
    Lighting 0 draws bit for bit as with no lights at all."""
    from addon.blender.evaluate.lighting import scene_lighting
    from addon.blender.render.camera import camera_from_blender
    from addon.blender.viewport import DrawSettings
    from addon.blender.viewport.scene_items import SceneItems

    bpy = bpy_empty
    guitar, _ = _scene(bpy, testdata)
    items, displays = SceneItems().collect(bpy.context)
    unlit = [replace(i, lighting=0.0) for i in items]
    assert any(i.deferred for i in unlit)  # the grade is the shader's: its rows move
    camera = camera_from_blender(bpy.context.scene, bpy.context.scene.camera)
    lighting = scene_lighting(bpy.context.evaluated_depsgraph_get())
    assert len(lighting.lights) == 4
    plain, drew = draw_offscreen(unlit, camera, displays)
    drew.close()
    with_lights, drew = draw_offscreen(unlit, camera, displays, DrawSettings(lighting=lighting))
    drew.close()
    np.testing.assert_array_equal(plain, with_lights)
    lit, drew = draw_offscreen([replace(unlit[0], lighting=1.0), unlit[1]], camera, displays,
                               DrawSettings(lighting=lighting))
    drew.close()
    assert not np.array_equal(plain, lit)  # and the table is read: lit, it differs


def test_solid_shading_shows_the_capture_unlit(gpu_ready, bpy_empty):
    from addon.blender.viewport.scene_items import lit_shading

    assert lit_shading(SimpleNamespace(shading=SimpleNamespace(type="MATERIAL")))
    assert lit_shading(SimpleNamespace(shading=SimpleNamespace(type="RENDERED")))
    assert not lit_shading(SimpleNamespace(shading=SimpleNamespace(type="SOLID")))
    assert not lit_shading(SimpleNamespace(shading=SimpleNamespace(type="WIREFRAME")))


def test_the_look_panel_says_where_the_capture_is_lit_once_lit(bpy_empty):
    """Splatline's viewport lights without shadows; a splat object Blender draws itself (5.3)
    shows lit in Splatline's engine alone (F12, Rendered shading with it)."""
    from addon.blender.data import native
    from addon.blender.ui.object_panels import NATIVE_LIGHTING_HINT, SPLATLINE_PT_look, VIEWPORT_LIGHTING_HINT
    from testing.engine_scene import add_splats, flat_splats
    from testing.ui_layout import RecordingLayout

    bpy = bpy_empty
    obj = add_splats(bpy, "s", flat_splats(np.zeros((4, 3)), np.full((4, 3), 0.5)))

    def labels():
        layout = RecordingLayout()
        SPLATLINE_PT_look.draw(SimpleNamespace(layout=layout), SimpleNamespace(object=obj))
        return [text for kind, text, _ in layout.record if kind == "label"]

    hints = {VIEWPORT_LIGHTING_HINT, NATIVE_LIGHTING_HINT}
    assert not hints & set(labels())
    obj.splatline.look.lighting = 0.3
    want = NATIVE_LIGHTING_HINT if native.has_native_splats() else VIEWPORT_LIGHTING_HINT
    assert hints & set(labels()) == {want}
    assert max(map(len, hints)) <= 64
    if native.has_native_splats():
        overlay_drawn(obj)  # set back to points: Splatline's overlay draws and lights it
        assert hints & set(labels()) == {VIEWPORT_LIGHTING_HINT}


def test_a_flattened_lit_capture_draws_as_the_reference_draws_it(gpu_ready, bpy_empty, testdata):
    """guitar.ply scaled to 0 along one axis (a keyed grow's first frame): its world matrix
    has no inverse; the viewport draws and lights it (its plane's normals) as the float64
    reference draws the engine's lit splats."""
    from addon.blender.viewport.scene_items import SceneItems

    bpy = bpy_empty
    guitar, _ = _scene(bpy, testdata)
    guitar.scale = (1.0, 1.0, 0.0)  # its local z is the world's y: a cut-out facing the camera
    bpy.context.view_layer.update()
    items, value = _viewport_against_engine(bpy, SceneItems(), shown=guitar)
    print(f"flattened guitar, lit: viewport against the reference {value:.1f} dB")
    assert abs(np.linalg.det(items[0].world[:3, :3])) == 0.0
    assert value >= 60.0
