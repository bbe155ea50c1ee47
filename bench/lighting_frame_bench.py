"""A real capture relit by a moving spot light, with a mesh's shadow on it (issue 43), through
Blender's own pipeline: python -m bench.lighting_frame_bench [runs].

The scene is bench/mesh_layer_bench's (testing/mesh_layer_scene.py: guitar.ply imported with
its RDF axes on the object, two cubes and a tilted plane from Blender's primitive operators,
drawn by Workbench), dark: a World of 0.03, the guitar at Look > Lighting 1, and a spot light
keyed to move along the guitar from frame 1 (behind the front cube, which shadows the body)
to frame 24 (over the neck). Rows, wall seconds of bpy.ops.render.render(write_still=True)
at frame 1 (the first render apart, then the median of `runs`): Lighting 0, Lighting 1 with the
light's shadow off, and on; their ratios to Lighting 0.

It writes docs/lighting.png, side by side (8-bit sRGB): frame 1 with the light's shadow off,
frame 1, frame 24."""
from __future__ import annotations

import pathlib
import statistics
import sys
import tempfile
import time

import numpy as np

from testing.paths import SHARED_TESTDATA

ROOT = pathlib.Path(__file__).resolve().parents[1]
SIZE = (480, 320)
RUNS = 3
PICTURE = ROOT / "docs" / "lighting.png"
FRAMES = (1, 24)


def _scene(bpy):
    """(scene, splat object, spot light object)."""
    from mathutils import Vector

    from addon.blender.compat import world_node_tree
    from testing.mesh_layer_scene import build

    bpy.ops.wm.read_factory_settings(use_empty=True)
    from addon import register

    if not hasattr(bpy.types.Object, "splatline"):
        register()
    hs, _objects, splats = build(bpy, SHARED_TESTDATA, *SIZE, count=0)
    scene = bpy.context.scene
    scene.render.film_transparent = False
    dark = (0.03, 0.03, 0.03)
    scene.world = bpy.data.worlds.new("dark")
    scene.world.color = dark
    world_node_tree(scene.world).nodes["Background"].inputs["Color"].default_value = (*dark, 1.0)
    splats.splatline.look.lighting = 1.0
    # frame 1: the light behind the front cube, as seen from the guitar's body, aimed at the
    # body (the cube's shadow in its pool of light); frame 24: moved along the guitar, aimed
    # at its neck
    cube = np.asarray(hs.meshes["front_cube"][0], np.float64).mean(0)
    along = np.array([0.0, 0.0, 1.0])  # the guitar's long axis (testing/holdout_scenes.py)
    body = hs.centre - 0.28 * hs.size * along
    neck = hs.centre + 0.3 * hs.size * along
    start = body + 2.2 * (cube - body)
    data = bpy.data.lights.new("Spot", "SPOT")
    data.spot_size, data.spot_blend, data.shadow_soft_size = np.radians(28.0), 0.25, 0.0
    data.energy = 120.0 * float(np.sum((start - body) ** 2))  # about 3 W/m^2 / pi at the body
    light = bpy.data.objects.new("Spot", data)
    scene.collection.objects.link(light)
    for frame, at, aim in ((FRAMES[0], start, body), (FRAMES[1], start + (neck - body), neck)):
        light.location = tuple(at)
        light.rotation_euler = (Vector(tuple(aim)) - light.location).to_track_quat("-Z", "Y").to_euler()
        light.keyframe_insert("location", frame=frame)
        light.keyframe_insert("rotation_euler", frame=frame)
    scene.frame_set(FRAMES[0])
    return scene, splats, light


def _times(bpy, runs: int) -> tuple[float, float]:
    from addon.blender.evaluate import lighting

    times = []
    for _ in range(runs + 1):
        lighting.clear()  # lit anew, as when the light moves between frames (not a cache hit)
        start = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        times.append(time.perf_counter() - start)
    return times[0], statistics.median(times[1:])


def _frame(bpy, scene, frame: int, path: pathlib.Path) -> np.ndarray:
    from addon.core.formats.webp import oiio

    scene.frame_set(frame)
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    return np.asarray(oiio().ImageBuf(str(path)).get_pixels(oiio().UINT8))


def main(argv=()) -> None:
    import bpy

    from addon.blender.compat import set_file_format
    from addon.core.formats.webp import oiio

    runs = next((int(a) for a in argv if a.isdigit()), RUNS)
    scene, splats, light = _scene(bpy)
    image = scene.render.image_settings
    set_file_format(image, "PNG")
    image.color_mode, image.color_depth = "RGB", "8"
    scene.render.use_file_extension = False
    out = pathlib.Path(tempfile.mkdtemp())
    scene.render.filepath = str(out / "frame.png")
    print(f"guitar.ply ({len(splats.data.points):,} splats), a spot light, 2 cubes and a plane (Workbench), "
          f"{SIZE[0]}x{SIZE[1]}, frame {FRAMES[0]}; wall s: first render, then median of {runs}")
    rows = []
    for label, level, shadow in (("Lighting 0", 0.0, True), ("Lighting 1, no shadow", 1.0, False),
                                 ("Lighting 1, the light's shadow", 1.0, True)):
        splats.splatline.look.lighting = level
        light.data.use_shadow = shadow
        first, median = _times(bpy, runs)
        rows.append(median)
        print(f"{label:32s} {first:7.3f} {median:7.3f}  {median / rows[0]:.2f}x", flush=True)
    light.data.use_shadow = False
    frames = [_frame(bpy, scene, FRAMES[0], out / "unshadowed.png")]
    light.data.use_shadow = True
    frames += [_frame(bpy, scene, f, out / f"frame{f}.png") for f in FRAMES]
    shade = frames[1].astype(np.int16).sum(2) < frames[0].astype(np.int16).sum(2) - 6
    print(f"the light's shadow darkens {int(shade.sum())} pixels of frame {FRAMES[0]} "
          f"(by more than 2 levels a channel)")
    both = np.concatenate(frames, axis=1)
    spec = oiio().ImageSpec(both.shape[1], both.shape[0], both.shape[2], oiio().UINT8)
    buf = oiio().ImageBuf(spec)
    buf.set_pixels(oiio().ROI(), np.ascontiguousarray(both))
    if not buf.write(str(PICTURE)):
        raise RuntimeError(f"{PICTURE}: {buf.geterror()}")
    print(f"wrote {PICTURE.relative_to(ROOT)} (frame {FRAMES[0]} without and with the shadow, frame {FRAMES[1]})")


if __name__ == "__main__":
    main(sys.argv[1:])
