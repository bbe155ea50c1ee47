"""Look > Lighting in the viewport (issue 43): the viewport's items are the engine's lit
splats, relit only when a light moves, drawn by Blender's GPU as the float64 reference
renders them; Solid shading shows the capture unlit (real bpy)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from addon.core import reference
from testing.engine_scene import add_splats
from testing.lit_scene import add_light, grey_world, top_camera, white_floor
from testing.viewport_scene import draw_offscreen, overlay_drawn, psnr


def _scene(bpy):
    floor = overlay_drawn(add_splats(bpy, "Floor", white_floor(spacing=0.05, size=1.6)))
    floor.splatline.look.lighting = 1.0
    bpy.ops.mesh.primitive_cube_add(size=0.4, location=(0.1, 0.0, 0.5))
    light = add_light(bpy, "SPOT", location=(0.3, 0.2, 1.5))
    top_camera(bpy, scale=1.8)
    grey_world(bpy, bpy.context.scene)
    bpy.context.view_layer.update()
    return floor, light


def test_viewport_draws_the_engines_lit_splats_and_relights_when_a_light_moves(gpu_ready, bpy_empty):
    from addon.blender.evaluate.items import collect_items
    from addon.blender.viewport.scene_items import SceneItems

    bpy = bpy_empty
    floor, light = _scene(bpy)
    viewport = SceneItems()
    items, _ = viewport.collect(bpy.context)
    engine = [i for i in collect_items(bpy.context.evaluated_depsgraph_get()) if i.key[0] == floor.name_full]
    np.testing.assert_array_equal(items[0].splats.sh_dc, engine[0].splats.sh_dc)
    again, _ = viewport.collect(bpy.context)
    assert again[0].splats is items[0].splats  # nothing moved: not relit
    light.location.x -= 0.5
    bpy.context.view_layer.update()
    moved, _ = viewport.collect(bpy.context)
    assert not np.array_equal(moved[0].splats.sh_dc, items[0].splats.sh_dc)

    from addon.blender.render.camera import camera_from_blender

    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = 64
    scene.render.resolution_percentage = 100
    camera = camera_from_blender(scene, scene.camera)
    drawn, drew = draw_offscreen(moved, camera)
    drew.close()
    want = reference.render(moved, camera).rgba
    value = psnr(drawn, want)
    print(f"lit floor, viewport (GPU) against the float64 reference: {value:.1f} dB")
    assert value >= 60.0


def test_solid_shading_shows_the_capture_unlit(gpu_ready, bpy_empty):
    from addon.blender.viewport.scene_items import lit_shading

    assert lit_shading(SimpleNamespace(shading=SimpleNamespace(type="MATERIAL")))
    assert lit_shading(SimpleNamespace(shading=SimpleNamespace(type="RENDERED")))
    assert not lit_shading(SimpleNamespace(shading=SimpleNamespace(type="SOLID")))
    assert not lit_shading(SimpleNamespace(shading=SimpleNamespace(type="WIREFRAME")))
