"""What Blender 5.3's own engines do with lights and native splats (issue 43).

    .venv-5.3/bin/python -m bench.native_lights_bench

1. Lights on splats: guitar.ply by `wm.ply_import` (turned upright), EEVEE and Cycles, 96x64,
   8 samples, rendered with no light and with a 20 W/m^2 sun plus a 5 kW red point light;
   printed: the covered pixels' mean colour both ways and the largest pixel difference.
2. Splats' shadows on meshes: a 1 m sheet of opaque flat splats 1 m above a 4 m mesh plane, a
   sun straight down, a camera under the sheet looking at the plane; printed: the plane's red
   under the sheet's middle without and with the splats.
3. Shadow only: the same sheet hidden from the camera (visible_camera off), seen from above;
   printed: the plane under the sheet and outside its shadow, without and with the sheet.
4. Splatline's engine with the mesh layer in EEVEE and Cycles: the same sheet and plane
   (testing/splat_shadow_scene.py), the sheet's shadow off and on (render/shadow_casters.py).
Each render runs in a child process of its own (5.3.0 may crash on a second EEVEE render or
at exit): the written EXR decides.
"""
from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np


def _lights_scene(bpy, on: bool):
    from testing.engine_scene import add_camera
    from testing.paths import SHARED_TESTDATA

    bpy.ops.wm.ply_import(filepath=str(SHARED_TESTDATA / "guitar.ply"))
    bpy.context.selected_objects[0].rotation_euler = (-np.pi / 2, 0, 0)
    add_camera(bpy, location=(0, -9, 0), target=(0, 0, 0))
    if on:
        scene = bpy.context.scene
        for kind, energy, colour, place in (("SUN", 20.0, (1, 1, 1), None), ("POINT", 5000.0, (1, 0.2, 0.2), (0, -3, 1))):
            data = bpy.data.lights.new(kind, kind)
            data.energy, data.color = energy, colour
            obj = bpy.data.objects.new(kind, data)
            scene.collection.objects.link(obj)
            if place:
                obj.location = place
            else:
                obj.rotation_euler = (1.2, 0, 0.5)
    return 96, 64


def _shadow_scene(bpy, on: bool):
    from testing.splat_shadow_scene import SIZE, sheet_over_plane

    sheet_over_plane(bpy, camera_z=0.5).hide_render = not on
    return SIZE, SIZE


def _shadow_only_scene(bpy, on: bool):
    """The sheet and plane of _shadow_scene seen from above, the sheet hidden from the camera
    (Object > Visibility > Camera off) but casting shadows: what a shadow-only caster gives."""
    from testing.splat_shadow_scene import SIZE, sheet_over_plane

    sheet = sheet_over_plane(bpy, camera_z=3.0)
    sheet.visible_camera = False
    sheet.hide_render = not on
    return SIZE, SIZE


def _child(case: str, engine: str, on: bool, out: str) -> None:
    import bpy

    from addon.blender.compat import set_file_format
    from addon.cli import blender_session

    blender_session.start()
    width, height = {"lights": _lights_scene, "shadow": _shadow_scene, "shadow_only": _shadow_only_scene}[case](bpy, on)
    scene = bpy.context.scene
    scene.render.engine = engine
    if engine == "CYCLES":
        scene.cycles.samples, scene.cycles.device = (8 if case == "lights" else 16), "CPU"
    else:
        scene.eevee.taa_render_samples = 8 if case == "lights" else 16
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.film_transparent = case == "lights"
    set_file_format(scene.render.image_settings, "OPEN_EXR")
    scene.render.filepath = out
    bpy.ops.render.render(write_still=True)


def _frame(case, engine, on, folder):
    from testing.engine_scene import read_exr_parts

    out = str(Path(folder) / f"{case}-{engine}-{int(on)}")
    subprocess.run([sys.executable, "-m", "bench.native_lights_bench", case, engine, str(int(on)), out],
                   capture_output=True)
    path = Path(out + ".exr")
    return next(iter(read_exr_parts(path).values())) if path.exists() else None


def main() -> None:
    from testing.blender_packages import use_bundled_packages

    use_bundled_packages()
    with tempfile.TemporaryDirectory() as folder:
        for engine in ("BLENDER_EEVEE", "CYCLES"):
            dark, lit = (_frame("lights", engine, on, folder) for on in (False, True))
            if dark is None or lit is None:
                print(f"{engine}: no frame written")
                continue
            covered = dark[..., 3] > 0.5
            print(f"{engine} lights on guitar.ply: {int(covered.sum())} covered pixels, mean RGB no light "
                  f"{dark[covered, :3].mean(0).round(4)}, with sun + red point {lit[covered, :3].mean(0).round(4)}, "
                  f"largest difference {float(np.abs(dark - lit).max()):.4g}")
        for engine in ("BLENDER_EEVEE", "CYCLES"):
            frames = [_frame("shadow", engine, on, folder) for on in (False, True)]
            if any(f is None for f in frames):
                print(f"{engine}: no frame written")
                continue
            red = [float(f[25:35, 25:35, 0].mean()) for f in frames]
            print(f"{engine} splat sheet over a mesh plane: the plane under it {red[0]:.3f} without, "
                  f"{red[1]:.3f} with the splats")
        for engine in ("BLENDER_EEVEE", "CYCLES"):
            frames = [_frame("shadow_only", engine, on, folder) for on in (False, True)]
            if any(f is None for f in frames):
                print(f"{engine}: no frame written")
                continue
            middle, edge = ([float(f[25:35, 25:35, 0].mean()) for f in frames],
                            [float(f[2:6, 2:6, 0].mean()) for f in frames])
            print(f"{engine} the sheet hidden from the camera, seen from above: the plane under it "
                  f"{middle[0]:.3f} without, {middle[1]:.3f} with the sheet; outside its shadow "
                  f"{edge[0]:.3f} and {edge[1]:.3f}")
        casters_rows(folder)


def casters_rows(folder) -> None:
    """Splatline's engine with its mesh layer in EEVEE and Cycles (render/shadow_casters.py):
    the sheet's shadow on the plane with the sheet's Visibility > Shadow off and on."""
    from testing.splat_shadow_scene import EDGE, MIDDLE, red, render_in_child

    for engine in ("EEVEE", "CYCLES"):
        off, _ = render_in_child(engine, "no_shadow", Path(folder) / f"casters-{engine}-off")
        on, _ = render_in_child(engine, "shadow", Path(folder) / f"casters-{engine}-on")
        if off is None or on is None:
            print(f"Splatline's engine, mesh layer {engine}: no frame written")
            continue
        print(f"Splatline's engine, mesh layer {engine}: the plane under the sheet {red(off, MIDDLE):.3f} "
              f"with its shadow off, {red(on, MIDDLE):.3f} on (outside {red(off, EDGE):.3f}, {red(on, EDGE):.3f})")


if __name__ == "__main__":
    if len(sys.argv) > 1:
        _child(sys.argv[1], sys.argv[2], sys.argv[3] == "1", sys.argv[4])
    else:
        main()
