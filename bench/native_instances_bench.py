"""What Blender 5.3's own engines do with instances of a native splat object (issue 45).

    .venv-5.3/bin/python -m bench.native_instances_bench

guitar.ply imported by Blender's own `wm.ply_import` (a GAUSSIAN_SPLAT PointCloud), then:
  alone       the object by itself
  collection  + a collection instance of it, moved sideways into view
  nodes       + Geometry Nodes Instance on Points (4 points, Object Info As Instance)
rendered by Workbench, EEVEE, Cycles (CPU, 4 samples) and Splatline's engine at 160x96.
Printed per engine and scene: the covered pixels (alpha > 0.5) and how many of the
instances' own places (each instance's projected centre, a 5x5 window) hold splats: an
engine that draws the instances covers them all. Blender's engines are run as they come,
through bpy.ops.render.render; without native splats (before 5.3) it says so and stops.
"""
from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ENGINES = {"WORKBENCH": "BLENDER_WORKBENCH", "EEVEE": "BLENDER_EEVEE", "CYCLES": "CYCLES",
           "SPLATLINE": "SPLATLINE"}
W, H = 160, 96
KINDS = ("alone", "collection", "nodes")


def _scene(bpy, testdata, kind):
    from addon.blender.data.pointcloud import read_positions
    from testing.engine_scene import add_camera
    from testing.instance_scene import collection_instance, in_collection, instance_on_points

    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy.types.Object, "splatline"):
        from addon import register

        register()
    bpy.ops.wm.ply_import(filepath=str(testdata / "guitar.ply"))
    obj = bpy.context.selected_objects[0]
    obj.rotation_euler = (-np.pi / 2, 0.0, 0.0)  # the file's RDF axes, up is -y
    bpy.context.view_layer.update()
    world = np.array(obj.matrix_world)
    p = read_positions(obj.data).astype(np.float64) @ world[:3, :3].T + world[:3, 3]
    lo, hi = np.percentile(p, [2, 98], axis=0)
    centre, size = (lo + hi) / 2, float(np.linalg.norm(hi - lo))
    if kind == "collection":
        collection_instance(bpy, in_collection(bpy, obj), (1.2 * size, 0.0, 0.0))
    elif kind == "nodes":
        # Object Info (Original) instances the object's local splats: turned as the object is
        offsets = [(1.2 * size * k, 0.0, 0.0) for k in (-1, 1)] + [(0.0, 0.0, 0.8 * size), (0.0, 0.0, -0.8 * size)]
        host = instance_on_points(bpy, offsets, obj)
        host.rotation_euler = obj.rotation_euler
    bpy.context.view_layer.update()
    local = np.linalg.inv(world)[:3, :3] @ centre + np.linalg.inv(world)[:3, 3]
    depsgraph = bpy.context.evaluated_depsgraph_get()
    places = [(np.array(i.matrix_world) @ np.append(local, 1.0))[:3] for i in depsgraph.object_instances
              if i.object.original == obj]
    add_camera(bpy, location=tuple(centre + (0.0, -4.5 * size, 0.0)), target=tuple(centre))
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = W, H, 100
    scene.render.film_transparent = True
    return scene, places


def _render(bpy, scene, engine, out: Path):
    scene.render.engine = ENGINES[engine]
    if engine == "CYCLES":
        scene.cycles.samples = 4
        scene.cycles.device = "CPU"
    from addon.blender.compat import set_file_format
    from testing.engine_scene import read_exr_parts

    # a one-layer EXR: with the tests' multilayer EXR and Z pass EEVEE 5.3.0 crashed here (SIGSEGV)
    set_file_format(scene.render.image_settings, "OPEN_EXR")
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = str(out)
    bpy.ops.render.render(write_still=True)
    return next(iter(read_exr_parts(out.with_suffix(".exr")).values()))


def _covered_places(scene, rgba, places) -> int:
    from addon.blender.render.camera import camera_from_blender

    camera = camera_from_blender(scene, scene.camera)
    uv = camera.project(np.asarray(places, np.float64))[:, :2]
    hit = 0
    for u, v in uv:
        x, y = int(u), int(v)
        if 0 <= x < W and 0 <= y < H and rgba[max(0, y - 2):y + 3, max(0, x - 2):x + 3, 3].max() > 0.3:
            hit += 1
    return hit


def main(argv=()) -> None:
    import bpy

    from addon import register
    from addon.blender.data import native
    from testing.blender_packages import use_bundled_packages
    from testing.paths import SHARED_TESTDATA

    use_bundled_packages()  # OpenImageIO, to read the EXRs
    register()
    if not native.has_native_splats():
        print(f"Blender {bpy.app.version_string}: no native splats (5.3+): nothing to measure")
        return
    if not argv:
        print(f"Blender {bpy.app.version_string}: guitar.ply (wm.ply_import) and its instances, {W}x{H}")
    kinds = [a for a in argv if a in KINDS] or KINDS
    engines = [a for a in argv if a in ENGINES] or list(ENGINES)
    if len(kinds) * len(engines) > 1:  # one process a render: a second one may crash 5.3.0
        for kind in kinds:
            for engine in engines:
                run = subprocess.run([sys.executable, "-m", "bench.native_instances_bench", kind, engine],
                                     capture_output=True, text=True)
                rows = [line for line in run.stdout.splitlines() if line.startswith(kind)]
                print(rows[0] if rows else f"{kind:10s} {engine:9s} failed: exit status {run.returncode}")
        return
    with tempfile.TemporaryDirectory() as tmp:
        for kind in kinds:
            for engine in engines:
                scene, places = _scene(bpy, SHARED_TESTDATA, kind)
                rgba = _render(bpy, scene, engine, Path(tmp) / f"{kind}_{engine}")
                covered = int((rgba[..., 3] > 0.5).sum())
                print(f"{kind:10s} {engine:9s} covered {covered:5d} px   places with splats "
                      f"{_covered_places(scene, rgba, places)}/{len(places)}")


if __name__ == "__main__":
    main(sys.argv[1:])
