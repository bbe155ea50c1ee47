"""python -m addon demo [--file CAPTURE] [--out DIR]: build, animate and render the demo.

With no argument and no external data: a procedural torus knot of 300k splats (SH degree 3)
reveals in along a glowing plane, swells under noise displacement, morphs into a procedural
planet and dissolves out by noise, under a keyframed orbiting camera. --file puts a capture
in place of the knot (its --splats most important splats); the planet is scaled to it.

Writes DIR/demo.blend (an ordinary, editable Splatline scene), renders it with the
SPLATLINE engine to DIR/exr/ (half-float multilayer EXR, scene-linear), and makes
DIR/demo.mp4 (H.264) and DIR/demo.png (a still of the reveal) from those EXRs through
Blender's compositor, so no splat is rendered twice.

The defaults fit the 10-minute budget of a shared 2-core CPU machine rendering through
Mesa llvmpipe. The Z pass is off by default: the offscreen renderer finds depth by
bisection, about log2(visible) extra draws per frame (measured 32 s against 3 s per frame
for 300k splats at 640x360 here); --z turns it on.
"""
from __future__ import annotations

import glob
import os
import statistics
import time

from . import UsageError, UserError, framing_options
from .options import add_axes
from .render import check_frame_memory, check_out_creatable, parse_frames, parse_resolution
from ..core import budget
from ..core.formats._common import splat_bytes
from .render_job import render_animation

DEFAULT_OUT = os.path.join("out", "demo")
DEFAULT_FRAMES = 120  # five seconds at 24 fps
DEFAULT_RESOLUTION = "640x360"
MIN_FRAMES = 6  # one frame or more per act of the animation


def configure(parser):
    parser.add_argument("--file", metavar="CAPTURE",
                        help="a splat file (any readable format) to use instead of the torus knot "
                             "(default: none, the knot)")
    add_axes(parser)
    parser.add_argument("--out", metavar="DIR", help=f"output folder (default: {DEFAULT_OUT})")
    parser.add_argument("--frames", metavar="A-B",
                        help=f"frame range to render (or one frame); the animation runs from frame 1 "
                             f"to B, at least {MIN_FRAMES} frames (default: 1-{DEFAULT_FRAMES}, or "
                             "--seconds)")
    parser.add_argument("--seconds", metavar="S",
                        help="length in seconds, instead of --frames: frames 1 to round(S x fps) "
                             f"(default: {DEFAULT_FRAMES} frames)")
    parser.add_argument("--fps", metavar="N",
                        help=f"frames per second, {framing_options.MIN_FPS}-{framing_options.MAX_FPS} "
                             f"(fractions such as 29.97 allowed; default: {framing_options.DEFAULT_FPS})")
    parser.add_argument("--resolution", metavar="WxH",
                        help=f"frame size, even numbers for H.264 (default: {DEFAULT_RESOLUTION})")
    parser.add_argument("--splats", type=int, default=300_000, metavar="N",
                        help="splats in the knot, or the cap on the capture's (default: 300000); "
                             "the morph target gets as many (paired by index), or three quarters "
                             "of a --file capture's (paired by spatial sort)")
    parser.add_argument("--z", action="store_true",
                        help="also render the Z pass into the EXRs (a Z frame costs about 1.1-1.3x a "
                             "colour frame; default: off)")


def _check(args) -> tuple[int, int]:
    args.out = args.out or DEFAULT_OUT
    args.resolution = args.resolution or DEFAULT_RESOLUTION
    width, height = parse_resolution(args.resolution)
    if width % 2 or height % 2:
        raise UsageError(f"--resolution {args.resolution}: H.264 needs an even width and height")
    timing = framing_options.read(args)  # --fps, --seconds; both with --frames refused
    args.fps = timing.fps or framing_options.DEFAULT_FPS
    if args.frames:
        args.first, args.last = parse_frames(args.frames)
        if args.last < MIN_FRAMES:
            raise UsageError(f"--frames {args.frames}: the animation (frames 1-{args.last}) needs at "
                             f"least {MIN_FRAMES} frames")
    else:
        args.first, args.last = 1, timing.frame_count(args.fps) or DEFAULT_FRAMES
        if args.last < MIN_FRAMES:
            raise UsageError(f"--seconds {args.seconds}: {args.last} frames at {args.fps:g} fps; the "
                             f"animation needs at least {MIN_FRAMES}")
    if args.splats < 1:
        raise UsageError(f"--splats {args.splats}: must be at least 1")
    check_frame_memory(f"--resolution {args.resolution}", width, height)
    # the showcase's splats, its morph target and their evaluated copy, with degree-3 SH
    budget.check(f"--splats {args.splats}", 3 * splat_bytes(args.splats, 45), "--max-memory",
                 "the splats, the morph target and their evaluated copy")
    if os.path.exists(args.out) and not os.path.isdir(args.out):  # os.makedirs: "File exists"
        raise UserError(f"--out {args.out}: exists and is not a folder (the demo writes "
                        "demo.blend, exr/, demo.mp4 and demo.png into a folder)")
    check_out_creatable(args.out, "the demo's files")  # before the capture is read
    if args.axes != "AUTO" and not args.file:
        raise UsageError(f"--axes {args.axes}: applies to a --file capture, not to the knot")
    if args.file and os.path.isdir(args.file):  # as `info` says it
        raise UserError(f"{args.file}: is a directory, not a splat file")
    if args.file and not os.path.isfile(args.file):
        raise UserError(f"{args.file}: no such file")
    return width, height


def _setup_render(bpy, scene, width, height, z_pass):
    from ..blender.data.presets import apply_render_preset

    scene.render.engine = "SPLATLINE"
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = True
    scene.render.use_stamp_date = scene.render.use_stamp_render_time = False
    scene.render.dither_intensity = 0.0
    scene.view_settings.view_transform = "Standard"  # the capture's own sRGB colours
    scene.view_settings.look = "None"
    apply_render_preset("exr_half_multilayer")
    for layer in scene.view_layers:
        layer.use_pass_z = z_pass
    # Relative to the .blend: `blender -b demo.blend -a` renders beside it.
    scene.render.filepath = "//exr/frame_####"
    scene.render.use_file_extension = True


def _clear_old_frames(folder: str) -> None:
    """Frames a longer earlier run left behind would pass for part of this sequence."""
    for path in glob.glob(os.path.join(folder, "frame_[0-9][0-9][0-9][0-9].exr")):
        os.remove(path)


def _render_exr(bpy, scene) -> list[float]:
    times, stopped, _ = render_animation(bpy, scene, scene.frame_end - scene.frame_start + 1,
                                      "render failed")
    if stopped:
        raise KeyboardInterrupt
    return times


def run(args) -> int:
    width, height = _check(args)
    wall = time.perf_counter()
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    from . import blender_session

    bpy = blender_session.start()
    from ..blender.data.capture_camera import set_frame_rate
    from ..blender.demo import scene as demo_scene, video as demo_video

    scene = bpy.context.scene
    what = args.file or f"a procedural torus knot of {args.splats:,} splats"
    print(f"building the demo scene from {what}", flush=True)
    t = time.perf_counter()
    source, target, _camera = demo_scene.build(
        bpy.context, splats=args.splats, frames=args.last, file=args.file, axes=args.axes,
        aspect=width / height)
    set_frame_rate(scene, args.fps)
    scene.frame_start = args.first  # the animation runs from 1; --frames A-B renders A..B of it
    _setup_render(bpy, scene, width, height, args.z)
    blend = os.path.join(out, "demo.blend")
    blender_session.save_blend(bpy, blend)  # no demo.blend1 beside it
    print(f"built {source.name} ({len(source.data.points):,} splats) morphing into {target.name} "
          f"({len(target.data.points):,}) in {time.perf_counter() - t:.1f} s; saved {blend}", flush=True)

    print(f"rendering frames {args.first}-{args.last} at {width}x{height} with the Splatline engine",
          flush=True)
    t = time.perf_counter()
    _clear_old_frames(os.path.join(out, "exr"))
    times = _render_exr(bpy, scene)
    render_s = time.perf_counter() - t
    frames = [scene.render.frame_path(frame=f) for f in range(scene.frame_start, scene.frame_end + 1)]

    t = time.perf_counter()
    video_scene = demo_video.encoding_scene(scene, frames[0], len(frames))
    mp4 = demo_video.encode(video_scene, os.path.join(out, "demo.mp4"))
    shown = min(max(demo_scene.showcase_frame(args.last) - args.first + 1, 1), len(frames))
    png = demo_video.still(video_scene, shown, os.path.join(out, "demo.png"))
    demo_video.remove_scene(video_scene)
    video_s = time.perf_counter() - t

    _report(out, blend, frames, mp4, png, times, render_s, video_s, time.perf_counter() - wall)
    return 0


def _report(out, blend, frames, mp4, png, times, render_s, video_s, wall_s) -> None:
    exr_mb = sum(os.path.getsize(f) for f in frames) / 1e6
    print(f"\n.blend  {blend}  ({os.path.getsize(blend) / 1e6:.1f} MB)")
    print(f"EXR     {os.path.dirname(frames[0])}/  ({len(frames)} frames, {exr_mb:.1f} MB)")
    print(f"MP4     {mp4}  ({os.path.getsize(mp4) / 1e6:.2f} MB)")
    print(f"PNG     {png}  ({os.path.getsize(png) / 1e3:.0f} KB)")
    print(f"render  {render_s:.1f} s for {len(times)} frames: median {statistics.median(times):.2f} s, "
          f"max {max(times):.2f} s per frame")
    print(f"video   {video_s:.1f} s (MP4 and PNG from the EXRs)")
    print(f"total   {wall_s:.1f} s", flush=True)
