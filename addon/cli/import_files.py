"""python -m addon import FILE... --blend OUT.blend: splat files into a new .blend.

A camera framing the imported captures (--camera, default an orbit; the framing flags of
framing_options.py) is added, as the scene has none, so `render OUT.blend` works on the
result. An orbit's scene runs 1-120 at 24 fps unless --seconds or --fps say otherwise.

Every file is read before anything is saved; the first bad file stops the command with
one line naming it, and no .blend is written.
"""
from __future__ import annotations

import os

from ..core.errors import SplatFormatError
from ..core.formats import table
from . import UsageError, UserError
from . import framing_options
from .writable import check_output_file
from .options import add_axes, add_bad_values, add_lod, add_selection, check_selection, preset_names


def configure(parser):
    parser.add_argument("files", nargs="+", metavar="FILE", help=f"{table.readable_help()} files")
    parser.add_argument("--blend", required=True, metavar="OUT.blend", help="the .blend file to write")
    add_selection(parser)
    add_lod(parser)
    add_axes(parser)
    add_bad_values(parser)
    parser.add_argument("--effect-preset", action="append", default=[], metavar="NAME",
                        help="apply an effect preset to every imported object, keyed from the "
                             "scene's start frame (repeatable; default: none): "
                             f"{preset_names('effects', '.json')} (presets/effects/), or one saved "
                             "in Blender; 'morph' needs two files and morphs the first into the second")
    framing_options.add_arguments(parser, render=False)


def _check_args(args) -> None:
    check_selection(args, UsageError)
    if os.path.isdir(args.blend):
        raise UserError(f"{args.blend}: is a directory")
    check_output_file(args.blend, "the .blend")  # before any file is read: one line
    args.framing = framing_options.read(args)


def run(args) -> int:
    _check_args(args)
    from .capture_scene import add_camera, check_camera_options, frame_range, load_camera_arg, seconds_range
    camera = load_camera_arg(args.camera)  # a bad track fails before any import
    check_camera_options(camera, args.framing)
    frames = explicit = seconds_range(camera, args.framing)
    if frames is None and camera == "orbit":
        frames = frame_range(camera)
    from .blender_session import save_blend, start

    bpy = start()
    from ..blender.data.files import import_file_with_report
    from ..blender.data.pointcloud import blender_bytes_for
    from ..core import budget

    budget.after_read(blender_bytes_for)  # Blender's copy, counted by each read's check
    from .capture_scene import use_capture_colours

    use_capture_colours(bpy.context.scene)  # a new scene: the capture's own colours, not AgX
    if frames is not None:  # before the effect presets, which key from the start frame
        bpy.context.scene.frame_start, bpy.context.scene.frame_end = frames

    from ..core.dynamic import is_dynamic_file
    from .capture_scene import import_capture, own_frames

    imported = []
    for path in args.files:
        if is_dynamic_file(path):  # a 4D capture: one object that plays by itself
            obj = import_capture(bpy, path, axes=args.axes)
            imported.append(obj)
            span = own_frames(obj)
            if explicit is None and len(args.files) == 1:  # the scene plays the capture
                frames = span
                bpy.context.scene.frame_start, bpy.context.scene.frame_end = frames
            print(f"{path}: {len(obj.data.points)} dynamic splats ({obj.splatline.dynamic.model}), "
                  f"frames {span[0]}-{span[1]}")
            continue
        try:
            obj, report = import_file_with_report(
                bpy.context, path, max_sh_degree=args.max_sh_degree, min_opacity=args.min_opacity,
                max_count=args.max_count, axes=args.axes, bad=args.bad_values, max_splats=args.max_splats,
                lod=args.lod)
        except OSError as exc:  # e.g. permission denied: still one line naming the file
            raise SplatFormatError(path, exc.strerror or str(exc)) from None
        imported.append(obj)
        extra = f"; {report.bad.summary()}" if report.bad.total else ""
        extra += f"; {report.dropped_sh}" if report.dropped_sh else ""
        print(f"{path}: {len(obj.data.points)} of {report.count_in_file} splats, "
              f"SH degree {report.sh_degree_in_file} -> {_degree(obj)}{extra}")
    _apply_effect_presets(bpy, args.effect_preset, imported)
    if bpy.context.scene.camera is None:
        try:
            add_camera(bpy, imported, camera, frames, args.framing, args.files[0])
        except ValueError as exc:
            raise UserError(f"{args.files[0]}: cannot frame the capture: {exc}") from None
    save_blend(bpy, args.blend)
    print(f"wrote {args.blend} ({len(args.files)} object(s))")
    return 0


def _apply_effect_presets(bpy, names, objects) -> None:
    from ..blender.data.effect_presets import apply_preset
    from ..blender.data.presets import find_preset
    from ..core import effect_presets

    frame = bpy.context.scene.frame_start
    for name in names:
        try:
            preset = effect_presets.load(find_preset(name, "effects", ".json"))
        except (KeyError, effect_presets.PresetError) as exc:
            raise UsageError(f"--effect-preset: {exc.args[0]}") from None
        morphs = preset.needs_target
        if morphs and len(objects) != 2:
            raise UsageError(f"--effect-preset {name}: morphs the first file into the second, "
                            f"so it needs exactly two files ({len(objects)} given)")
        for obj in objects[:1] if morphs else objects:
            try:  # all or nothing per object; no .blend is written after an error
                apply_preset(obj, preset, frame, target=objects[1] if morphs else None)
            except effect_presets.PresetError as exc:
                raise UsageError(f"--effect-preset: {exc}") from None
        print(f"{preset.label}: keyed from frame {frame}")


def _degree(obj) -> int:
    from ..blender.data.pointcloud import sh_count_in
    from ..core.splats import sh_degree_for

    return sh_degree_for(sh_count_in(obj.data.attributes))
