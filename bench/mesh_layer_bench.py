"""Splats and meshes in one final frame (issue 25): what the mesh layer costs beside the splat
layer, through Blender's own pipeline (python -m bench.mesh_layer_bench [runs] [--eevee]).

The scene is testing/holdout_scenes.guitar_scene built from real primitives
(testing/mesh_layer_scene.py: every splat of guitar.ply, a cube in front of it, one behind, a
tilted plane through its middle) at SIZE, rendered by bpy.ops.render.render(write_still=True)
to a 32-bit multilayer EXR with the Z pass. Rows:
- Meshes: Ignored: the splats alone (no holdout, no compositor);
- Meshes: Hide Splats Only: the splat layer with the holdout (read from the depsgraph per
  frame, cached while unchanged), no compositor;
- Meshes: Drawn with each Mesh Engine: the frame as users get it (the mesh scene rendered
  by Blender's engine inside the same job, and the compositor's Alpha Over);
- the mesh scene alone, rendered by that engine (render.render(scene=...)): its own share.
Wall seconds per frame, the first frame of each row apart (shader compiles, GL context),
then the median of `runs`. EEVEE (and Cycles at 16 samples) only with --eevee: on a CPU
rasterizer (Mesa llvmpipe) EEVEE takes about a minute for a small frame.

It also writes docs/mesh_layer.png: the final frame of the scene (Workbench, Standard view,
the world's grey behind) as the README shows it.
"""
from __future__ import annotations

import os
import pathlib
import statistics
import sys
import tempfile
import time

from testing.paths import SHARED_TESTDATA

ROOT = pathlib.Path(__file__).resolve().parents[1]
SIZE = (480, 320)
RUNS = 3
PICTURE = ROOT / "docs" / "mesh_layer.png"


def _scene(bpy):
    from testing.mesh_layer_scene import build

    testdata = SHARED_TESTDATA
    bpy.ops.wm.read_factory_settings(use_empty=True)
    from addon import register

    if not hasattr(bpy.types.Object, "splatline"):
        register()
    hs, objects, splats = build(bpy, testdata, *SIZE, count=0)
    return bpy.context.scene, splats


def _time(bpy, scene, path, runs, render_scene=None):
    """(first frame s, median s of runs) of render.render(write_still) of scene."""
    from addon.cli.render import configure_output

    configure_output(scene, "EXR", str(path.parent))
    scene.render.filepath = str(path)
    times = []
    for _ in range(runs + 1):
        t = time.perf_counter()
        bpy.ops.render.render(write_still=True, scene=(render_scene or scene).name)
        times.append(time.perf_counter() - t)
    return times[0], statistics.median(times[1:])


def main(argv=()) -> None:
    import bpy

    runs = next((int(a) for a in argv if a.isdigit()), RUNS)
    eevee = "--eevee" in argv
    scene, splats = _scene(bpy)
    settings = scene.splatline.render
    print(f"guitar.ply ({len(splats.data.points):,} splats), 2 cubes and a plane, "
          f"{SIZE[0]}x{SIZE[1]}, EXR with Z; load {os.getloadavg()[0]:.2f} "
          f"(wall s per frame: first, then median of {runs}; EEVEE and Cycles: of 1)")
    print(f"{'row':44s} {'first':>8s} {'median':>8s}")
    out = pathlib.Path(tempfile.mkdtemp()) / "frame.exr"
    rows = [("Meshes: Ignored (splats alone)", "IGNORE", None),
            ("Meshes: Hide Splats Only (splat layer)", "HOLDOUT", None),
            ("Meshes: Drawn, Workbench", "DRAW", "WORKBENCH")]
    if eevee:
        rows += [("Meshes: Drawn, EEVEE (16 samples)", "DRAW", "EEVEE"),
                 ("Meshes: Drawn, Cycles CPU (16 samples)", "DRAW", "CYCLES")]
    for label, mode, engine in rows:
        settings.meshes = mode
        companion = settings.mesh_scene
        if engine is not None:
            settings.mesh_engine = engine
            _samples(companion, 16)
        first, median = _time(bpy, scene, out, runs if engine in (None, "WORKBENCH") else 1)
        print(f"{label:44s} {first:8.3f} {median:8.3f}", flush=True)
        if engine is not None:
            from addon.cli.render import configure_output

            for name in ("resolution_x", "resolution_y", "resolution_percentage"):
                setattr(companion.render, name, getattr(scene.render, name))
            configure_output(companion, "EXR", str(out.parent))
            companion.render.filepath = str(out)
            first, median = _time(bpy, companion, out, runs if engine == "WORKBENCH" else 1)
            print(f"{'  the mesh scene alone, ' + engine.title():44s} {first:8.3f} {median:8.3f}",
                  flush=True)
    _picture(bpy, scene)


def _samples(companion, n):
    eevee = getattr(companion, "eevee", None)
    if eevee is not None and "taa_render_samples" in eevee.bl_rna.properties:
        eevee.taa_render_samples = n
    cycles = getattr(companion, "cycles", None)
    if cycles is not None and "samples" in cycles.bl_rna.properties:
        cycles.samples = n
        cycles.use_denoising = False


def _picture(bpy, scene):
    """docs/mesh_layer.png: the final frame, Workbench, the world's grey behind, 8-bit RGB."""
    from addon.blender.compat import set_file_format, world_node_tree
    from addon.blender.render import mesh_layer

    settings = scene.splatline.render
    settings.meshes, settings.mesh_engine = "DRAW", "WORKBENCH"
    scene.render.film_transparent = False
    grey = (0.18, 0.18, 0.18)
    scene.world = bpy.data.worlds.new("grey")
    scene.world.color = grey  # what Workbench draws behind
    world_node_tree(scene.world).nodes["Background"].inputs["Color"].default_value = (*grey, 1.0)
    mesh_layer.sync(scene)  # the mesh scene takes the film and the world
    image = scene.render.image_settings
    set_file_format(image, "PNG")
    image.color_mode, image.color_depth, image.compression = "RGB", "8", 100
    scene.render.use_file_extension = False
    scene.render.filepath = str(PICTURE)
    bpy.ops.render.render(write_still=True)
    print(f"wrote {PICTURE.relative_to(ROOT)}")


if __name__ == "__main__":
    main(sys.argv[1:])
