"""Render engine cost per frame, through Blender's pipeline (python -m bench engine).

For guitar.ply at a few frame sizes, the stages measured on their own: gathering the
splats from the depsgraph, the offscreen GL render (warm), and the sRGB -> scene-linear
conversion with the flip into Blender's buffer; then whole frames as Blender runs them:
an F12-style still (no file; a render job of its own, so it includes creating the GL
context and uploading the splats) and one frame of a 3-frame animation render writing
an 8-bit PNG (the renderer reused across frames, as on a farm). The last column is the
baseline ratio: animation frame / GL render alone, i.e. what the Blender integration
and the file cost on top of the renderer. Medians of REPEATS runs.
"""
from __future__ import annotations

import pathlib
import tempfile

from bench.common import median_s
from testing.paths import SHARED_TESTDATA

REPEATS = 3
SIZES = ((320, 180), (960, 540))  # llvmpipe takes seconds a frame; add 1920x1080 on a GPU


def _scene(bpy):
    from testing.engine_scene import guitar_scene

    scene, _, _ = guitar_scene(bpy, SHARED_TESTDATA, [1, 2, 3], 64, 64, count=0)
    scene.camera.animation_data_clear()  # every frame the same view, so rows compare
    scene.view_layers[0].use_pass_z = True  # the engine then runs the GL depth pass, as here
    return scene


def _row(bpy, scene, renderer, width, height):
    from addon.blender.render.camera import camera_from_blender
    from addon.blender.evaluate.items import collect_items
    from addon.blender.render.film import result_rect

    scene.render.resolution_x, scene.render.resolution_y = width, height
    depsgraph = bpy.context.evaluated_depsgraph_get()
    camera = camera_from_blender(scene, scene.camera, depsgraph)
    items = collect_items(depsgraph)
    options = scene.splatline.render.options()
    renderer.render(items, camera, options)  # warm: uploads, shader compile
    gather = median_s(lambda: collect_items(depsgraph), REPEATS)
    gl = median_s(lambda: renderer.render(items, camera, options), REPEATS)
    out = renderer.render(items, camera, options)
    convert = median_s(lambda: result_rect(out.rgba), REPEATS)  # the engine's conversion
    still = median_s(lambda: bpy.ops.render.render(), REPEATS)
    frames = scene.frame_end - scene.frame_start + 1
    anim = median_s(lambda: bpy.ops.render.render(animation=True), 1) / frames
    return gather, gl, convert, still, anim


def main():
    from addon.blender.compat import set_file_format
    from addon.cli import blender_session
    from addon.gl import OffscreenRenderer

    bpy = blender_session.start()
    scene = _scene(bpy)
    set_file_format(scene.render.image_settings, "PNG")
    with tempfile.TemporaryDirectory() as tmp, OffscreenRenderer() as renderer:
        count = sum(len(o.data.points) for o in scene.objects if o.type == "POINTCLOUD")
        print(f"guitar.ply, {count:,} splats, GL: {renderer.gl_info.get('GL_RENDERER', '?')}")
        print(f"{'size':>10} {'gather ms':>10} {'gl ms':>8} {'convert ms':>11} {'F12 ms':>8} "
              f"{'anim ms':>8} {'anim/gl':>8}")
        for width, height in SIZES:
            scene.render.filepath = str(pathlib.Path(tmp) / f"{width}_####")
            gather, gl, convert, still, anim = _row(bpy, scene, renderer, width, height)
            print(f"{f'{width}x{height}':>10} {gather * 1e3:10.1f} {gl * 1e3:8.1f} {convert * 1e3:11.1f} "
                  f"{still * 1e3:8.1f} {anim * 1e3:8.1f} {anim / gl:8.2f}", flush=True)


if __name__ == "__main__":
    main()
