"""Splatline's engine beside Blender 5.3's own splat engines (python -m bench native).

    .venv-5.3/bin/python -m bench.native_engines_bench [runs]

One capture, one camera, every engine: guitar.ply imported by Blender's own `wm.ply_import`
(a native splat PointCloud, `type == 'GAUSSIAN_SPLAT'`, identity matrix: the file's own RDF
axes, y down and z forward), seen from the front (core/framing: the capture's up is -y),
rendered through Blender's pipeline (`render.render(write_still=True)`, a 32-bit float EXR)
by Splatline's engine, EEVEE, Cycles (CPU, fixed sample counts, no denoiser, its default
1.5 px pixel filter) and Workbench (default Studio lighting). The same object goes to every
engine: Splatline's engine draws any splat object, native or not.

Colour: the EXR holds the engine's premultiplied scene-linear film (the view transform is set
to Standard, the plain sRGB curve, but an EXR is written before any view transform). Each
frame is turned into the renderers' space, display-referred sRGB, premultiplied, float
(un-premultiply, core/colorspace's sRGB curve, premultiply: the inverse of Splatline's own
conversion) and compared as floats with the float64 reference (core/reference) of the same
items, under the camera render/camera.py makes of Blender's, with the scene's Splatline
options but every splat composited (no early termination, as render_bench); Splatline's
engine keeps its default early termination, as users get it. PSNR over the whole RGBA frame
(the empty background counts, and agrees), over the covered pixels (reference alpha >= 0.5),
and of alpha alone (no colour space touches it). The last column compares the covered
pixels with a model of what Blender's engines do (MODELS): the reference blending in linear
light and with gsplat's antialiased opacity; the model rows show what each change alone
does to the reference.

Time: wall seconds of a whole render (Blender's pipeline and the EXR write included); the
first frame of each engine (GL context, shader compiles, BVH build) on its own, then the
median of `runs` frames after it (fewer for the slow engines: `engines`). The load average
is printed with the table: on a shared machine the times move, the PSNRs do not. Without
native splats (Blender before 5.3) the table is skipped with a message.
"""
from __future__ import annotations

import dataclasses
import math
import os
import pathlib
import statistics
import sys
import tempfile
import time

import numpy as np

from bench.common import psnr
from testing.paths import SHARED_TESTDATA

ROOT = pathlib.Path(__file__).resolve().parents[1]
CAPTURE = SHARED_TESTDATA / "guitar.ply"
SIZE = (180, 320)  # portrait: the guitar stands; on llvmpipe EEVEE and Cycles take seconds a frame
COVERED = 0.5  # reference alpha at and above which a pixel counts as covered
EEVEE_SAMPLES = 16
CYCLES_SAMPLES = (16, 64)  # 64: how much of the gap at 16 is sampling noise
RUNS = 5  # frames after the first, for the fast engines
# The reference changed the way Blender's engines seem to differ from 3DGS: blending in linear
# light, then also gsplat's antialiased opacity (each splat's opacity times
# sqrt(det(cov) / det(cov + 0.3 I)): less alpha for splats under a pixel or two).
MODELS = ("reference, linear light", "reference, linear light, antialiased")


def _eevee_id(bpy) -> str:
    """EEVEE's engine identifier in this Blender (BLENDER_EEVEE_NEXT in 4.2 .. 4.5)."""
    items = {i.identifier for i in bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items}
    return next((e for e in ("BLENDER_EEVEE", "BLENDER_EEVEE_NEXT") if e in items), "BLENDER_EEVEE")


def _cycles(samples):
    def setup(scene):
        scene.cycles.device = "CPU"
        scene.cycles.samples = samples
        scene.cycles.use_adaptive_sampling = False  # exactly `samples` per pixel
        scene.cycles.use_denoising = False
    return setup


def _eevee(scene):
    scene.eevee.taa_render_samples = EEVEE_SAMPLES


def engines(bpy, runs: int):
    """(label, engine id, settings, timed frames after the first) of each row."""
    rows = [("Splatline (moderngl)", "SPLATLINE", lambda scene: None, runs),
            (f"EEVEE, {EEVEE_SAMPLES} samples", _eevee_id(bpy), _eevee, max(1, runs // 4))]
    rows += [(f"Cycles CPU, {s} spp, no denoiser", "CYCLES", _cycles(s), max(1, runs * 32 // (5 * s)))
             for s in CYCLES_SAMPLES]  # runs 5: 2 frames at 16 spp, 1 at 64
    rows.append(("Workbench (Studio light)", "BLENDER_WORKBENCH", lambda scene: None, max(1, runs // 2)))
    return rows


def build_scene(bpy, width: int, height: int):
    """guitar.ply through Blender's own importer, a camera on its front, an EXR output."""
    import mathutils

    from addon.blender.compat import set_file_format
    from addon.blender.data.pointcloud import read_positions
    from addon.core.framing import capture_axes, clip_range, fit_box_distance, front_pose, robust_bounds

    assert bpy.ops.wm.ply_import(filepath=str(CAPTURE)) == {"FINISHED"}
    obj = bpy.context.view_layer.objects.active
    scene = bpy.context.scene
    data = bpy.data.cameras.new("bench camera")
    camera = bpy.data.objects.new("bench camera", data)
    scene.collection.objects.link(camera)
    scene.camera = camera
    bounds = robust_bounds(read_positions(obj.data))  # identity matrix: object space is world
    up, forward = capture_axes("RDF", np.eye(4))
    data.sensor_fit = "VERTICAL"
    tan_y = math.tan(data.angle_y / 2)
    # fit_box_distance reads the box's height off world z; here up is -y: hand it the box
    # turned so (right, forward, up) are its (x, y, z).
    turn = np.stack([np.cross(forward, up), forward, up])
    low, high = turn @ bounds.low, turn @ bounds.high
    box = type(bounds)(turn @ bounds.centre, np.minimum(low, high), np.maximum(low, high))
    distance = 1.1 * fit_box_distance(box, tan_y * width / height, tan_y)
    camera.matrix_world = mathutils.Matrix(front_pose(bounds, up, forward, distance).tolist())
    data.clip_start, data.clip_end = clip_range(bounds, distance)
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
    r.film_transparent = True
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure, scene.view_settings.gamma = 0.0, 1.0
    set_file_format(r.image_settings, "OPEN_EXR")
    r.image_settings.color_depth = "32"
    return scene, obj


def reference_frames(bpy, scene):
    """The float64 reference of the scene's splat items under Blender's camera (every splat
    composited: no early termination, as Blender's engines and render_bench), its seconds,
    and the models: {label: the reference changed as named}. All premultiplied display sRGB."""
    from addon.blender.evaluate.items import collect_items
    from addon.blender.render.camera import camera_from_blender
    from addon.core import reference

    depsgraph = bpy.context.evaluated_depsgraph_get()
    camera = camera_from_blender(scene, scene.camera, depsgraph)
    items = collect_items(depsgraph)
    options = dataclasses.replace(scene.splatline.render.options(), early_termination=False)
    start = time.perf_counter()
    out = reference.render(items, camera, options)
    seconds = time.perf_counter() - start
    linear = linear_light(items, camera)
    models = {
        MODELS[0]: display(reference.render(linear, camera, options).rgba),
        MODELS[1]: display(reference.render(linear, camera,
                                            dataclasses.replace(options, antialiased=True)).rgba),
    }
    return np.asarray(out.rgba, np.float64), seconds, models


def linear_light(items, camera):
    """The items with each splat's colour (as this camera sees it: SH and colour matrix
    applied) turned to scene-linear and stored as its only SH band. The reference then blends
    in linear light, as Blender's engines do, with 3DGS's footprints, alphas and order: its
    premultiplied output is linear, to be put through display() like an engine's film."""
    from addon.core.colorspace import srgb_to_linear
    from addon.core.preprocess import project
    from addon.core.scene import IDENTITY_COLOR
    from addon.core.sh import C0

    out = []
    for item in items:
        rgb = project(item, camera).rgb  # invalid splats keep some colour; they are culled anyway
        dc = (srgb_to_linear(np.nan_to_num(rgb)) - 0.5) / C0
        splats = dataclasses.replace(item.splats, sh_dc=dc.astype(np.float32),
                                     sh_rest=np.zeros((item.splats.count, 0, 3), np.float32))
        out.append(dataclasses.replace(item, splats=splats, color_matrix=IDENTITY_COLOR.copy(),
                                       sh_degree=0, key=None))
    return out


def display(linear):
    """Premultiplied scene-linear RGBA as premultiplied display sRGB (float64): un-premultiply,
    the sRGB curve (what the Standard view transform applies), premultiply."""
    from addon.core.colorspace import linear_to_srgb

    linear = np.asarray(linear, np.float64)
    alpha = linear[..., 3:]
    straight = np.divide(linear[..., :3], alpha, out=np.zeros_like(linear[..., :3]), where=alpha > 0)
    return np.concatenate([linear_to_srgb(np.maximum(straight, 0.0)) * alpha, alpha], axis=-1)


def read_display(path):
    """An EXR's premultiplied scene-linear RGBA as premultiplied display sRGB, float64, top-down."""
    import OpenImageIO as oiio

    buf = oiio.ImageBuf(str(path))
    linear = np.asarray(buf.get_pixels(oiio.FLOAT), np.float64)
    if buf.has_error or linear.ndim != 3:
        raise RuntimeError(f"could not read {path}: {buf.geterror()}")
    return display(linear)


def time_engine(bpy, scene, engine, setup, runs, path):
    """(first frame s, median s of `runs` frames after it, the last frame in display sRGB)."""
    scene.render.engine = engine
    setup(scene)
    scene.render.filepath = str(path)
    seconds = []
    for _ in range(runs + 1):
        start = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        seconds.append(time.perf_counter() - start)
    return seconds[0], statistics.median(seconds[1:]), read_display(path)


def scores(frame, ref, model):
    """PSNR dB against the reference of the RGBA frame, of its covered pixels' RGBA, and of
    alpha alone (which no colour space touches: a gap there is coverage, not blending); then
    of the covered pixels' RGBA against `model` (the last of MODELS)."""
    covered = ref[..., 3] >= COVERED
    return (psnr(frame, ref), psnr(frame[covered], ref[covered]), psnr(frame[..., 3], ref[..., 3]),
            psnr(frame[covered], model[covered]))


def main(runs: int = RUNS):
    from addon.cli import blender_session
    from addon.core.formats.webp import _bundled_site_packages

    bpy = blender_session.start()
    from addon.blender.data import native

    if not native.has_native_splats():
        print(f"skipped: Blender {bpy.app.version_string} has no native splats (PointCloud.type "
              f"GAUSSIAN_SPLAT, 5.3+); run it with bpy 5.3: .venv-5.3/bin/python -m bench native")
        return
    site = _bundled_site_packages()  # Blender's OpenImageIO reads the EXRs
    if site is not None and site not in sys.path:
        sys.path.append(site)
    width, height = SIZE
    scene, obj = build_scene(bpy, width, height)
    ref, ref_s, models = reference_frames(bpy, scene)
    covered = int((ref[..., 3] >= COVERED).sum())
    rest = sum(1 for a in obj.data.attributes if a.name.startswith("radiance:sh_"))
    print(f"guitar.ply ({len(obj.data.points):,} splats, SH {round(math.sqrt(rest + 1)) - 1}) "
          f"by wm.ply_import, {width}x{height}, Blender {bpy.app.version_string}; "
          f"{covered:,} covered pixels (reference alpha >= {COVERED}); PSNR dB in premultiplied "
          f"display sRGB float against the float64 reference ({ref_s:.1f} s a frame) and, last "
          f"column, against the {MODELS[-1]!r} model; load average {os.getloadavg()[0]:.1f}")
    print(f"{'engine':<38} {'first s':>8} {'median s':>9} {'frames':>6} {'frame':>7} "
          f"{'covered':>8} {'alpha':>7} {'covered vs model':>17}")

    def row(label, first, median, n, frame):
        times = f"{first:8.2f} {median:9.2f} {n:6d}" if n else f"{'-':>8} {'-':>9} {'-':>6}"
        print(f"{label:<38} {times} " + " ".join(f"{v:{w}.2f}" for v, w in
                                                 zip(scores(frame, ref, models[MODELS[-1]]), (7, 8, 7, 17))),
              flush=True)

    for label, frame in models.items():
        row(label, 0, 0, 0, frame)
    with tempfile.TemporaryDirectory(prefix="splatline-native-bench-") as tmp:
        for label, engine, setup, n in engines(bpy, runs):
            path = pathlib.Path(tmp) / f"{engine.lower()}.exr"
            first, median, frame = time_engine(bpy, scene, engine, setup, n, path)
            row(label, first, median, n, frame)
    print("load average (1, 5, 15 min) at the end: " + ", ".join(f"{x:.1f}" for x in os.getloadavg()))


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else RUNS)
