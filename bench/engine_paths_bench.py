"""The engine's render paths on one scene, through bpy.ops.render.render, against the
float64 reference (python -m bench engine_paths).

Scene: testing/engine_paths_scene.two_object_scene (test64.ply and a degree-1 blob
interleaved in depth), 160x120, transparent film, Z pass off (colour only: the
gpu-module path has no depth pass). Each still is its own
render job, so "ms/frame" includes what a job costs (moderngl: making its context and
uploading; gpu module: shader and textures) and writing the EXR. PSNR is over the
premultiplied display-referred RGBA (the EXR converted back from scene-linear). Median
of RUNS stills after one warm-up.
"""
from __future__ import annotations

import pathlib
import statistics
import tempfile

from testing.paths import SHARED_TESTDATA

RUNS = 7
PATHS = ("OFFSCREEN", "GPU_MODULE")


def main() -> None:
    from testing.blender_packages import use_bundled_packages

    use_bundled_packages()  # the EXRs are read with Blender's bundled OpenImageIO
    import bpy
    from testing.engine_paths_scene import reference_frame, render_exr, to_display, two_object_scene
    from testing.viewport_scene import psnr

    from addon import register
    from addon.blender.render import backend as render_backend

    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy.types.Object, "splatline"):
        register()
    scene = two_object_scene(bpy, SHARED_TESTDATA)
    ref = reference_frame(bpy, scene)
    print(f"{'path':<64} {'PSNR dB':>8} {'ms/frame':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        for kind in PATHS:
            path = pathlib.Path(tmp) / kind
            render_exr(bpy, scene, path, kind, depth=False)  # warm-up
            runs = [render_exr(bpy, scene, path, kind, depth=False) for _ in range(RUNS)]
            rgba = runs[-1][0]
            ms = 1000 * statistics.median(r[2] for r in runs)
            print(f"{render_backend.last_label():<64} {psnr(to_display(rgba), ref.rgba):8.1f} {ms:9.1f}")


if __name__ == "__main__":
    main()
