"""The offscreen renderer keeps its GL context off Blender's (DESIGN.md): after a final
render, Blender's own gpu module still draws, and after that the engine still renders."""
from __future__ import annotations

import numpy as np

from testing.engine_scene import add_camera, add_splats, flat_splats, read_exr_parts, set_output, setup_render
from testing.viewport_scene import draw_offscreen, psnr


def _render(bpy, scene, path):
    set_output(scene, "EXR", path)
    bpy.ops.render.render(write_still=True)
    return read_exr_parts(path.with_suffix(".exr"))["ViewLayer.Combined"]


def test_viewport_draws_between_final_renders(bpy_empty, tmp_path):
    from addon.blender.render.camera import camera_from_blender
    from addon.blender.evaluate.items import collect_items
    from testing.headless import ensure_gpu
    from addon.core.colorspace import linear_to_srgb

    bpy = bpy_empty
    ensure_gpu()
    rng = np.random.default_rng(4)
    add_splats(bpy, "s", flat_splats(rng.uniform(-1, 1, (40, 3)), rng.uniform(0, 1, (40, 3)),
                                     scale=0.25, opacity=0.8))
    add_camera(bpy)
    scene = setup_render(bpy, 64, 48)
    first = _render(bpy, scene, tmp_path / "first")

    depsgraph = bpy.context.evaluated_depsgraph_get()
    drawn, _ = draw_offscreen(collect_items(depsgraph), camera_from_blender(scene, scene.camera))
    # The engine's film back in the renderers' space: premultiplied sRGB.
    alpha = first[..., 3:]
    straight = np.divide(first[..., :3], alpha, out=np.zeros_like(first[..., :3]), where=alpha > 0)
    engine_srgb = np.concatenate([linear_to_srgb(straight) * alpha, alpha], axis=-1)
    assert drawn[..., 3].max() > 0.5
    # Two implementations of one semantics (gpu module vs moderngl), each held to the
    # reference at 60 dB (test_viewport.py explains the bar; measured here: 99 dB, 144 dB
    # before the viewport's data became half floats). The
    # old 35 dB bar passed a missing low-pass term (39 dB), so this one is the reference's.
    assert psnr(drawn, engine_srgb) > 60.0

    second = _render(bpy, scene, tmp_path / "second")
    np.testing.assert_array_equal(second, first)
