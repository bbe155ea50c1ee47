"""python -m addon render SCENE.blend --out DIR: render a .blend with the Splatline engine.

`render CAPTURE --out DIR [--camera orbit|capture|front|side|TRACK.json]` renders a bare
splat file: it is imported as the UI imports it, a camera is added (capture_scene.py; its
flags: framing_options.py), and the scene is rendered by the same code as a .blend. Its
output defaults to RGBA PNG, its film is transparent. A movie (MP4) is one file named by
Blender from the frame range, frame_START-END.mp4 in --out; its path is printed.

Renders through Blender's own animation pipeline (what `blender -b -a` runs), so frame
step, border, resolution percentage and every output format behave as in Blender.
Progress and the time of each frame come from Blender's render handlers.

Farm use: splitting a frame range across runs gives the same files as one run. For
that the files must not carry metadata that differs between runs or machines: Blender
stamps the date and render time by default, and pads the frame number to the digits of
the run's last frame ("01" in a 1-10 run, "1" in a 1-5 run). This command turns every
such field off (UNREPRODUCIBLE_STAMPS) unless --keep-stamp is given.

Ctrl+C (SIGINT) stops at the frame being rendered: every finished frame stays on disk
and readable, the unfinished one is not written, and the command exits with 130.
A second Ctrl+C stops at once.
"""
from __future__ import annotations

import errno
import os
import re
import statistics
import time

from . import UsageError, UserError
from . import framing_options
from .capture_scene import is_blend
from .framing_options import parse_frames
from .options import add_axes, preset_names
from .render_job import is_movie, render_animation
from .writable import check_folder
from ..blender.compat import media_type, set_file_format
from ..core import budget
from ..core.formats import table

FORMATS = ("EXR", "PNG", "MP4")
STILL_VIEWS = ("front", "side", "capture")  # framing_options.VIEWS but the orbit
EXR_FORMATS = ("OPEN_EXR", "OPEN_EXR_MULTILAYER")  # Blender's file formats that --half applies to
_BOOL = {"1": True, "true": True, "on": True, "yes": True,
         "0": False, "false": False, "off": False, "no": False}


# Blender's own limits (RNA hard_min/hard_max of Scene.frame_start/frame_end and
# RenderSettings.resolution_x/y, the same on 4.5-5.3; tests/cli/test_one_line_errors.py checks
# them against RNA): a value outside is refused, never clamped.
MAX_FRAME = framing_options.MAX_FRAME
MIN_RESOLUTION, MAX_RESOLUTION = 4, 65536


# Metadata fields that differ between runs of the same frames (frame: its zero padding
# follows the run's last frame), or between farm machines.
UNREPRODUCIBLE_STAMPS = ("use_stamp_date", "use_stamp_render_time", "use_stamp_frame",
                         "use_stamp_frame_range", "use_stamp_memory", "use_stamp_hostname")


def configure(parser):
    parser.add_argument("blend", metavar="SCENE.blend|CAPTURE",
                        help=f"the .blend to render, or a splat file ({table.readable_help()}) to "
                             "import and render under an added camera")
    parser.add_argument("--out", required=True, metavar="DIR",
                        help="folder for the frames (frame_0001.png, ...) or the movie "
                             "(frame_START-END.mp4, e.g. frame_0001-0120.mp4)")
    parser.add_argument("--frames", metavar="A-B", help="frame range (or one frame); default: the scene's "
                                                        "(a capture: see --camera and --seconds)")
    framing_options.add_arguments(parser)
    add_axes(parser)
    parser.add_argument("--step", type=int, metavar="N", help="render every Nth frame; default: the scene's")
    output = parser.add_mutually_exclusive_group()
    output.add_argument("--format", type=str.upper, choices=FORMATS,
                        help="EXR (multilayer, Combined + Depth), PNG (8-bit) or MP4 (H.264); "
                             "default: the .blend's own output settings")
    output.add_argument("--preset", metavar="NAME",
                        help=f"a render-output preset: {preset_names('render', '.py')} "
                             "(presets/render/), or one saved in Blender; other flags given "
                             "override it (default: none)")
    parser.add_argument("--half", action="store_true", help="EXR: half floats instead of full floats (default: full)")
    parser.add_argument("--resolution", metavar="WxH", help="output size in pixels, percentage set to 100 (default: the .blend's; "
                             "1920x1080 for a capture)")
    parser.add_argument("--engine-option", action="append", default=[], metavar="NAME=VALUE",
                        help="a Splatline render setting, e.g. key_bits=16, gpu_sort=off, "
                             "antialiased=on, renderer=REFERENCE|GPU_MODULE|OFFSCREEN|AUTO, "
                             "motion_blur_samples=8 (with the .blend's motion blur on), "
                             "meshes=DRAW|HOLDOUT|IGNORE, mesh_engine=WORKBENCH|EEVEE|CYCLES "
                             "(repeatable; default: the .blend's settings)")
    parser.add_argument("--keep-stamp", action="store_true",
                        help="keep the render date, time, frame and host in the files' metadata (not "
                             "reproducible; default: off)")


def parse_resolution(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text or "")
    if match is None or int(match.group(1)) < 1 or int(match.group(2)) < 1:
        raise UsageError(f"--resolution {text!r}: expected WxH, e.g. 1920x1080")
    width, height = int(match.group(1)), int(match.group(2))
    if not (MIN_RESOLUTION <= width <= MAX_RESOLUTION and MIN_RESOLUTION <= height <= MAX_RESOLUTION):
        raise UsageError(f"--resolution {text.strip()}: width and height must lie in "
                         f"{MIN_RESOLUTION}-{MAX_RESOLUTION} (Blender's limit)")
    return width, height


def check_frame_memory(what: str, width: int, height: int, splats=(0, 0)) -> None:
    """The memory budget on the frame buffers of a width x height render, and the renderer's
    buffers for splats (count, higher-SH floats of the largest degree) (core/budget.py)."""
    count, rest = splats
    engine = f", the renderer's buffers for {count} splats" if count else ""
    budget.check(what, budget.frame_bytes(width, height) + budget.render_bytes(count, rest), "--max-memory",
                 f"{width}x{height} frame buffers: RGBA and depth, float32, "
                 f"{budget.FRAME_COPIES} copies{engine}")


def _plan_capture_memory(scene) -> None:
    """A capture's read is checked for all that follows it: Blender's copy, the renderer's
    buffers and the frame's (core/budget.after_read)."""
    from ..blender.data.pointcloud import blender_bytes_for
    r = scene.render
    frame = budget.frame_bytes(r.resolution_x * r.resolution_percentage // 100,
                               r.resolution_y * r.resolution_percentage // 100)
    budget.after_read(lambda n, rest: blender_bytes_for(n, rest) + budget.render_bytes(n, rest) + frame)


def _scene_splats(bpy) -> tuple[int, int]:
    """(splats in the scene's splat objects, the most higher-SH floats a splat of them has)."""
    from ..blender.data.pointcloud import sh_count_in
    from ..blender.data.sources import is_splat_object

    count = rest = 0
    for obj in bpy.context.scene.objects:
        if is_splat_object(obj, with_splat_data=True):
            count += len(obj.data.points)
            rest = max(rest, 3 * sh_count_in(obj.data.attributes))
    return count, rest


def set_engine_option(settings, text: str) -> None:
    """NAME=VALUE onto the RenderSettings group, typed by its RNA definition."""
    name, sep, value = text.partition("=")
    name, value = name.strip(), value.strip()
    # What every PropertyGroup has (rna_type, name) is RNA's, not a render setting; a
    # POINTER (mesh_scene) is Splatline's own bookkeeping.
    base = settings.bl_rna.base
    inherited = {p.identifier for p in base.properties} if base is not None else {"rna_type"}
    props = {p.identifier: p for p in settings.bl_rna.properties
             if p.identifier not in inherited and p.type != "POINTER"}
    if not sep or name not in props:
        known = ", ".join(props)
        raise UsageError(f"--engine-option {text!r}: expected NAME=VALUE with NAME one of {known}")
    prop = props[name]
    if prop.type == "BOOLEAN":
        if value.lower() not in _BOOL:
            raise UsageError(f"--engine-option {name}: {value!r} is not on/off")
        setattr(settings, name, _BOOL[value.lower()])
    elif prop.type == "ENUM":
        choices = {item.identifier.upper(): item.identifier for item in prop.enum_items}
        if value.upper() not in choices:
            raise UsageError(f"--engine-option {name}: {value!r} is not one of {', '.join(choices.values())}")
        setattr(settings, name, choices[value.upper()])
    else:
        try:
            setattr(settings, name, int(value) if prop.type == "INT" else float(value))
        except (TypeError, ValueError) as exc:
            raise UsageError(f"--engine-option {name}: {value!r}: {exc}") from None


def configure_output(scene, fmt: str, out_dir: str, half: bool = False) -> None:
    """Blender's output settings for one of FORMATS (through compat: 5.0 wants media_type first)."""
    render, image = scene.render, scene.render.image_settings
    render.filepath = os.path.join(os.path.abspath(out_dir), "frame_####")
    render.use_file_extension = True
    if fmt == "EXR":
        set_file_format(image, "OPEN_EXR_MULTILAYER")
        image.color_depth = "16" if half else "32"
        image.exr_codec = "ZIP"
        for layer in scene.view_layers:
            layer.use_pass_z = True
    elif fmt == "PNG":
        set_file_format(image, "PNG")
        image.color_mode = "RGBA" if render.film_transparent else "RGB"
        image.color_depth = "8"
    elif fmt == "MP4":
        set_file_format(image, "FFMPEG")
        image.color_mode = "RGB"
        render.ffmpeg.format = "MPEG4"
        render.ffmpeg.codec = "H264"


def _check_video_size(scene, args) -> None:
    """An option error (exit 2) naming the option that chose the size or the movie; the
    .blend's own movie output at its own odd size is the .blend's (exit 1)."""
    r = scene.render
    w, h = r.resolution_x * r.resolution_percentage // 100, r.resolution_y * r.resolution_percentage // 100
    if not (w % 2 or h % 2):
        return
    why = f"MP4 (H.264) needs an even width and height, not {w}x{h}"
    if args.resolution:
        raise UsageError(f"--resolution {args.resolution.strip()}: {why}")
    if args.format or args.preset:
        flag = f"--format {args.format}" if args.format else f"--preset {args.preset}"
        raise UsageError(f"{flag}: {why} (the frame size of {args.blend}); give an even --resolution")
    raise UserError(f"{args.blend}: its MP4 output: {why}; give an even --resolution")


def _prepare(bpy, args):
    scene = bpy.context.scene
    scene.render.engine = "SPLATLINE"
    _set_frame_size(scene, args)  # first: its preset's settings yield to the explicit flags
    if args.frames:
        scene.frame_start, scene.frame_end = parse_frames(args.frames)
    _set_rate_and_length(scene, args.framing)
    if args.step is not None:
        scene.frame_step = args.step
    for option in args.engine_option:
        set_engine_option(scene.splatline.render, option)
    # Meshes: the mesh layer (a scene of the meshes, composited under the splats) set up
    # now, after the engine and its options; it is also set up on file load, but a .blend
    # whose engine was another until this command (or a capture) has none yet.
    from ..blender.render import mesh_layer
    mesh_layer.sync(scene)
    if args.format:
        configure_output(scene, args.format, args.out, args.half)
    else:
        scene.render.filepath = os.path.join(os.path.abspath(args.out), "frame_####")
    if args.half:
        _use_half(scene, args)
    if media_type(scene.render.image_settings) == "VIDEO":
        _check_video_size(scene, args)
    r = scene.render
    check_frame_memory(f"--resolution {args.resolution.strip()}" if args.resolution else
                       f"{args.blend}: its resolution", r.resolution_x * r.resolution_percentage // 100,
                       r.resolution_y * r.resolution_percentage // 100, _scene_splats(bpy))
    if not args.keep_stamp:
        for field in UNREPRODUCIBLE_STAMPS:
            setattr(scene.render, field, False)
    if scene.camera is None:
        raise UserError(f"{args.blend}: scene {scene.name!r} has no camera")
    return scene


def _use_half(scene, args) -> None:
    """--half on the output the flags, preset or .blend chose: refused where that is not EXR
    (it used to be ignored there without a word)."""
    image = scene.render.image_settings
    if image.file_format not in EXR_FORMATS:
        source = f"--preset {args.preset}" if args.preset else args.blend
        raise UsageError(f"--half: half floats are for EXR output; the output format of "
                         f"{source} is {image.file_format}")
    image.color_depth = "16"


def _set_frame_size(scene, args) -> None:
    """--preset's and --resolution's frame size (a capture's camera is framed for it)."""
    if args.preset:  # first, so that --resolution overrides it
        _apply_preset(args.preset)
    if args.resolution:
        scene.render.resolution_x, scene.render.resolution_y = parse_resolution(args.resolution)
        scene.render.resolution_percentage = 100


def _set_rate_and_length(scene, options) -> None:
    """--fps and --seconds on a .blend (a capture's scene has them already)."""
    if options.fps is not None:
        from ..blender.data.capture_camera import set_frame_rate
        set_frame_rate(scene, options.fps)
    count = options.frame_count(scene.render.fps / scene.render.fps_base)
    if count is not None:
        if scene.frame_start + count - 1 > MAX_FRAME:
            raise UsageError(f"--seconds {options.seconds:g}: ends past frame {MAX_FRAME} (Blender's limit)")
        scene.frame_end = scene.frame_start + count - 1


def _apply_preset(name: str) -> None:
    from ..blender.data.presets import apply_render_preset
    try:
        apply_render_preset(name)
    except KeyError as exc:
        raise UsageError(f"--preset: {exc.args[0]}") from None


def _check_args(args) -> None:
    """What can be checked without starting Blender (fast one-line errors)."""
    if os.path.isdir(args.blend):  # as `info` says it
        raise UserError(f"{args.blend}: is a directory, not a .blend or a splat file")
    if not os.path.isfile(args.blend):
        kind = ".blend file" if args.blend.lower().endswith(".blend") else "file"
        raise UserError(f"{args.blend}: no such {kind}")
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise UserError(f"--out {args.out}: exists and is not a folder")
    check_out_creatable(args.out)
    if args.frames:
        parse_frames(args.frames)
    if args.resolution:
        width, height = parse_resolution(args.resolution)
        check_frame_memory(f"--resolution {args.resolution.strip()}", width, height)
        if args.format == "MP4" and (width % 2 or height % 2):  # known before Blender starts
            raise UsageError(f"--resolution {args.resolution.strip()}: MP4 (H.264) needs an even "
                             f"width and height")
    if args.step is not None and not 1 <= args.step <= MAX_FRAME:
        raise UsageError(f"--step {args.step}: must lie in 1-{MAX_FRAME}")
    if args.half:  # the format known before Blender starts (a preset's or a .blend's: _use_half)
        known = args.format or (None if args.preset or is_blend(args.blend) else "PNG")
        if known not in (None, "EXR"):
            why = "" if args.format else " (a capture's default)"
            raise UsageError(f"--half: half floats are for EXR output, not {known}{why}; "
                             "use --format EXR, or drop --half")
    if args.camera is not None and is_blend(args.blend):
        raise UsageError(f"--camera {args.camera}: applies to a capture, not to a .blend (it has its cameras)")
    if args.axes != "AUTO" and is_blend(args.blend):
        raise UsageError(f"--axes {args.axes}: applies to a capture, not to a .blend (its objects "
                         "carry their own rotation)")
    args.framing = framing_options.read(args, for_blend=is_blend(args.blend))


def check_out_creatable(out, what: str = "frames") -> None:
    """The folder is made only once the input is known good (nothing half-made on bad input),
    so a path under a file is refused here, as os.makedirs would refuse it."""
    parent = os.path.abspath(out)
    while not os.path.exists(parent) and os.path.dirname(parent) != parent:
        parent = os.path.dirname(parent)
    if not os.path.isdir(parent):
        raise NotADirectoryError(errno.ENOTDIR, os.strerror(errno.ENOTDIR), out)
    check_folder(parent, what)


def _open_scene(args):
    """bpy with the scene to render: the .blend, or a bare capture with a camera added
    (the track is read before Blender starts, so a bad one costs no import)."""
    from . import blender_session
    if not is_blend(args.blend):
        from . import capture_scene
        camera = capture_scene.load_camera_arg(args.camera)
        capture_scene.check_camera_options(camera, args.framing)
        frames = parse_frames(args.frames) if args.frames else None
        frames = capture_scene.seconds_range(camera, args.framing, frames)
        _say_still(camera, frames)
        bpy = blender_session.start()
        _set_frame_size(bpy.context.scene, args)  # the framing fits the frame's aspect
        _plan_capture_memory(bpy.context.scene)
        capture_scene.build(bpy, args.blend, camera, frames, args.framing, args.axes)
        if not args.format and not args.preset:
            args.format = "PNG"  # the factory scene's output would be an opaque 8-bit RGB
        return bpy
    return blender_session.start(os.path.abspath(args.blend))  # SplatFormatError if unreadable


def _say_still(camera, frames) -> None:
    """A still view over several frames renders the same picture each time: said once."""
    if camera in STILL_VIEWS and frames is not None and frames[1] > frames[0]:
        print(f"note: --camera {camera} is a still view: its {frames[1] - frames[0] + 1} frames "
              f"({frames[0]}-{frames[1]}) are identical (--camera orbit moves)", flush=True)


def run(args) -> int:
    _check_args(args)
    bpy = _open_scene(args)
    scene = _prepare(bpy, args)
    os.makedirs(args.out, exist_ok=True)  # after the input and options are known good: nothing half-made
    total = len(range(scene.frame_start, scene.frame_end + 1, scene.frame_step))
    print(f"rendering {total} frame(s) {scene.frame_start}-{scene.frame_end} of {args.blend} "
          f"at {scene.render.resolution_x}x{scene.render.resolution_y} "
          f"{scene.render.resolution_percentage}% to {args.out}", flush=True)
    start = time.perf_counter()
    times, stopped, movie = render_animation(bpy, scene, total, args.blend)
    if stopped:
        if is_movie(scene):  # the movie holds the frames that finished, and its name says which
            kept = f"wrote {movie}" if movie else "no movie written (an earlier one is as it was)"
            print(f"interrupted: {kept}", flush=True)
        else:
            print(f"interrupted: {len(times)} finished frame(s) kept in {args.out}", flush=True)
        return 130
    median = statistics.median(times) if times else 0.0
    print(f"done: {len(times)} frame(s) in {time.perf_counter() - start:.2f} s, "
          f"median {median:.3f} s per frame", flush=True)
    if movie:
        # Blender names the movie from the range: frame_0001-0120.mp4 for frame_#### over 1-120
        print(f"wrote {movie}", flush=True)
    return 0
