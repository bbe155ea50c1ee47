"""What the commands do with a dynamic (4D) capture: `info` shows its model, time range and
count (`--stats`: the fraction of splats alive at its start, middle and end); `convert`
writes it to another dynamic format where the model fits, bakes one moment (`--time T`) or
a frame range (`--frames A-B`, a numbered sequence) to any writable format; `render` and
`import` bring it into Blender as one object that plays by itself (capture_scene.py,
import.py)."""
from __future__ import annotations

import os

from ..core.dynamic import bake, read_dynamic, timeline, to_fourdgs, to_spacetime, write_dynamic
from ..core.formats import format_for_output, write
from . import UsageError
from .framing_options import DEFAULT_FPS, MAX_FPS, MIN_FPS, number, parse_frames
from .writable import check_output_file

DYNAMIC_EXTENSIONS = (".ply", ".splatv", ".4dgs")
FRAME_MARK = "#"


def summary(path, stats: bool = False, max_splats=None) -> dict:
    capture = read_dynamic(path)
    info = {
        "file": os.fspath(path), "format": capture.source, "dynamic": True, "model": capture.model,
        "count": capture.count, "segments": capture.segments, "sh_degree": capture.sh_degree,
        "axes": capture.axes, "time_unit": capture.unit,
        "time_range": [capture.t_start, capture.t_end],
        "fps": capture.fps, "duration": capture.duration, "start": capture.start,
        "dropped": dict(capture.dropped), "bytes_in_memory": capture.nbytes,
        "file_bytes": os.path.getsize(path),
    }
    if stats:
        middle = (capture.t_start + capture.t_end) / 2.0
        info["alive"] = {name: float(capture.alive_mask(t).mean()) if capture.count else 0.0
                         for name, t in (("start", capture.t_start), ("middle", middle),
                                         ("end", capture.t_end))}
    return info


def print_summary(info: dict) -> None:
    unit = "s" if info["time_unit"] == "seconds" else " (segment time)"
    rows = [("file", info["file"]), ("format", info["format"]), ("model", info["model"]),
            ("splats", f"{info['count']:,}"), ("segments", info["segments"]),
            ("time range", f"{info['time_range'][0]:g} to {info['time_range'][1]:g}{unit}"),
            ("SH degree", info["sh_degree"]), ("axes", info["axes"]),
            ("dropped", ", ".join(f"{k} {v}" for k, v in info["dropped"].items()) or "none")]
    if "alive" in info:
        rows.append(("alive", ", ".join(f"{k} {v:.1%}" for k, v in info["alive"].items())))
    width = max(len(k) for k, _ in rows)
    for key, value in rows:
        print(f"{key:<{width}}  {value}")


def convert(args, path) -> int:
    """`convert DYNAMIC OUT`: a dynamic format, or a baked moment or frame range."""
    if len(args.input) != 1:
        raise UsageError("a dynamic capture converts on its own, not merged with other inputs")
    out = os.fspath(args.output)
    if args.time is not None or args.frames is not None:
        return _bake(args, path, out)
    ext = os.path.splitext(out)[1].lower()
    if ext not in DYNAMIC_EXTENSIONS:
        raise UsageError(f"{path} is a dynamic capture: write it as {', '.join(DYNAMIC_EXTENSIONS)}, "
                         f"or bake one moment (--time T) or frames (--frames A-B) to {ext or out}")
    check_output_file(out, f"the {ext[1:]} output")
    capture = read_dynamic(path)
    fitted = to_fourdgs(capture, args.seconds_per_unit) if ext == ".4dgs" else \
        capture if capture.model != "4dgs" else to_spacetime(capture)
    write_dynamic(out, fitted)
    print(f"{path} ({capture.source}, {capture.count} splats, {capture.model}) -> {out} "
          f"({fitted.model}, {fitted.count} splats)")
    return 0


def _bake(args, path, out: str) -> int:
    capture = read_dynamic(path)
    if args.time is not None:
        fmt = format_for_output(out)
        check_output_file(out, f"the {fmt} output")
        splats = bake(capture, args.time)
        write(out, splats, fmt)
        print(f"{path} at t = {args.time:g} -> {out} ({fmt}, {splats.count} splats alive)")
        return 0
    first, last = parse_frames(args.frames)
    if FRAME_MARK not in out:
        raise UsageError(f"--frames {first}-{last}: the output names each frame's file with "
                         f"{FRAME_MARK}'s for its number (e.g. frames/{os.path.basename(out)}_####.ply)")
    unit = timeline.SEGMENT if capture.unit == "segment" else timeline.SECONDS
    mapping = timeline.Mapping(capture.t_start, capture.t_end, start_frame=1.0,
                               frames_per_unit=timeline.default_frames_per_unit(unit, _fps(args.fps)))
    names = [_numbered(out, frame) for frame in range(first, last + 1)]
    fmt = format_for_output(names[0])
    for name in names[:1]:
        check_output_file(name, f"the {fmt} frames")
    for frame, name in zip(range(first, last + 1), names):
        write(name, bake(capture, timeline.capture_time(mapping, frame)), fmt)
    print(f"{path} frames {first}-{last} -> {names[0]} ... {names[-1]} ({fmt}, {len(names)} files)")
    return 0


def _fps(text) -> float:
    return DEFAULT_FPS if text is None else number("--fps", text, MIN_FPS, MAX_FPS)


def _numbered(pattern: str, frame: int) -> str:
    """The pattern's first run of #'s replaced by the frame number, zero-padded to its width."""
    head = pattern.index(FRAME_MARK)
    run = len(pattern[head:]) - len(pattern[head:].lstrip(FRAME_MARK))
    return pattern[:head] + str(frame).zfill(run) + pattern[head + run:]
