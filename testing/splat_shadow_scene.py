"""The scene of the splat-shadows-on-meshes tests (render/shadow_casters.py): a 1 m sheet of
opaque flat splats 1 m above a 4 m mesh plane, a sun straight down, and an orthographic
camera between them looking down, so the frame shows the plane (the sheet is behind the
camera) through Splatline's engine with its mesh layer. Each render runs in a child process
(5.3.0's EEVEE may crash on a second render or at exit): the written EXR decides.

    python -m testing.splat_shadow_scene ENGINE CASE OUT
ENGINE: EEVEE, CYCLES or WORKBENCH (the Mesh Engine); CASE: shadow, no_shadow (the sheet's
Visibility > Shadow off), faded (Look > Opacity keyed 1 at frame 1, 0 at frame 2; frame 2
rendered), unfaded (the same, frame 1 rendered); capture, capture_no_shadow: guitar.ply
imported by the operator over the plane (capture_over_plane), its shadow on and off.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SIZE = 60
MIDDLE = (slice(25, 35), slice(25, 35))   # under the sheet's middle
EDGE = (slice(2, 6), slice(2, 6))         # outside its shadow


def sheet_over_plane(bpy, camera_z: float = 0.5):
    """The sheet (returned), the plane, the sun and an orthographic camera at height
    camera_z looking down (0.5: between them, the sheet behind it)."""
    from testing.engine_scene import add_splats
    from testing.lit_scene import add_light, white_floor

    sheet = add_splats(bpy, "Sheet", white_floor(spacing=0.03, size=1.0))
    sheet.location = (0.0, 0.0, 1.0)
    bpy.ops.mesh.primitive_plane_add(size=4)
    add_light(bpy, "SUN", location=(0.0, 0.0, 5.0))
    cam = bpy.data.cameras.new("Camera")
    cam.type, cam.ortho_scale = "ORTHO", 3.0
    obj = bpy.data.objects.new("Camera", cam)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = (0.0, 0.0, camera_z)
    bpy.context.scene.camera = obj
    return sheet


def capture_over_plane(bpy):
    """guitar.ply imported by Splatline's operator (its RDF axes turned on the object), turned
    a further 90 degrees about x to lie along the floor, over a mesh plane; a sun straight
    down and an orthographic camera between them looking down. Returns the capture."""
    import math

    import numpy as np

    from addon.blender.data.capture_camera import splat_world_points
    from testing.lit_scene import add_light
    from testing.paths import SHARED_TESTDATA

    assert bpy.ops.import_scene.splatline_gaussians(filepath=str(SHARED_TESTDATA / "guitar.ply")) == {"FINISHED"}
    capture = bpy.context.active_object
    capture.rotation_euler.x += math.pi / 2
    bpy.context.view_layer.update()
    lo, hi = np.percentile(splat_world_points([capture]), [2, 98], axis=0)
    floor = lo[2] - 0.5 * (hi[2] - lo[2]) - 0.2
    bpy.ops.mesh.primitive_plane_add(size=4.0 * float(np.max(hi - lo)), location=(*(0.5 * (lo + hi))[:2], floor))
    add_light(bpy, "SUN", location=(0.0, 0.0, hi[2] + 1.0))
    cam = bpy.data.cameras.new("Camera")
    cam.type, cam.ortho_scale = "ORTHO", CAPTURE_VIEW * float(np.max((hi - lo)[:2]))
    obj = bpy.data.objects.new("Camera", cam)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = (*(0.5 * (lo + hi))[:2], 0.5 * (floor + lo[2]))
    bpy.context.scene.camera = obj
    return capture


CAPTURE_VIEW = 1.4   # the camera's width over the capture's longer side


def build(bpy, engine: str, case: str):
    sheet = capture_over_plane(bpy) if case.startswith("capture") else sheet_over_plane(bpy)
    sheet.visible_shadow = not case.endswith("no_shadow")
    if case in ("faded", "unfaded"):
        look = sheet.splatline.look
        look.opacity = 1.0
        look.keyframe_insert("opacity", frame=1)
        look.opacity = 0.0
        look.keyframe_insert("opacity", frame=2)
    scene = bpy.context.scene
    scene.render.engine = "SPLATLINE"
    scene.splatline.render.meshes = "DRAW"
    scene.splatline.render.mesh_engine = engine
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    return sheet


def render(engine: str, case: str, out: str) -> None:
    import bpy

    from addon.blender.compat import set_file_format
    from addon.blender.render import mesh_layer
    from addon.cli import blender_session

    blender_session.start()
    build(bpy, engine, case)
    scene = bpy.context.scene
    mesh_layer.sync(scene)
    meshes = mesh_layer.mesh_scene(scene)
    meshes.eevee.taa_render_samples = 16
    meshes.cycles.samples, meshes.cycles.device = 16, "CPU"
    set_file_format(scene.render.image_settings, "OPEN_EXR")
    scene.render.filepath = out
    scene.frame_set(2 if case == "faded" else 1)
    bpy.ops.render.render(write_still=True)


def render_in_child(engine: str, case: str, out: Path, python: str = sys.executable):
    """(RGBA float32 frame or None, stderr) of one render in a child process."""
    from testing.engine_scene import read_exr_parts
    from testing.paths import REPO

    run = subprocess.run([python, "-m", "testing.splat_shadow_scene", engine, case, str(out)],
                         capture_output=True, text=True, cwd=REPO, timeout=600)
    exr = Path(str(out) + ".exr")
    return (next(iter(read_exr_parts(exr).values())) if exr.exists() else None), run.stderr


def red(frame, where) -> float:
    return float(frame[where][..., 0].mean())


if __name__ == "__main__":
    from testing.blender_packages import use_bundled_packages

    use_bundled_packages()
    render(*sys.argv[1:4])
