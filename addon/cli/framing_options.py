"""The framing flags of a bare capture's scene (`render CAPTURE`, `import`): the view
(--camera), how much of the frame the capture fills, the camera's height and lens, and the
frame rate and length. Read into a plain `Framing` before Blender starts, so a bad value
costs one line (exit 2) and nothing else.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

from . import UsageError
from ..core import framing

VIEWS = ("orbit", "capture", "front", "side")
DEFAULT_FPS = 24  # Blender's own default scene rate, which the CLI's scenes keep
DEFAULT_ORBIT_FRAMES = 120  # five seconds at 24 fps: one slow turn
MIN_FILL, MAX_FILL = 0.05, 1.0
MAX_ELEVATION = 89.0  # straight down the up axis the frame would have no "up"
MAX_AZIMUTH = 360.0
# Blender's limits (RNA of Camera.lens (hard min; soft max: its slider's), Camera.angle and
# RenderSettings.fps on 4.5-5.3; tests/cli/test_cli_framing.py checks them against RNA).
MIN_LENS, MAX_LENS = 1.0, 5000.0
MIN_FOV, MAX_FOV = 0.367, 172.847
MIN_FPS, MAX_FPS = 1, 32767
MAX_FRAME = 1048574  # Scene.frame_start/frame_end's hard max (render.py's limits use it too)

CAMERA_HELP = (
    "a view or a camera track. Views, in the capture's upright frame (its up is the file's "
    "up axis): orbit (default: one turn counter-clockwise round the capture over the frame "
    "range, starting at front, ELEVATION degrees up); front (a still, level view: a guess, as no "
    "format records where the capture's cameras stood. It looks at the side the capture's flat "
    "splats face, which is the side it was photographed from, along the subject's broad face "
    "(the level axis along which its splats spread least) when that is near: guitar.ply's top, "
    "strings and pickups. A capture from all round has no such side: front is then the broad "
    "face seen from the side the file's camera stood on. --azimuth turns it); side "
    "(a still view a quarter turn counter-clockwise from front, seen from above); capture (a "
    "still view along the capture's own camera direction, the file's forward axis: +z for "
    "3DGS/COLMAP PLY; no format Splatline reads stores a camera's position or lens, so it stands "
    "back as the other views do). A camera track: a SuperSplat settings.json, an .ssproj or its "
    "document.json, or {frameRate, frames: [{position, target, fov, up}]}")


@dataclass(frozen=True)
class Framing:
    """The framing flags, checked; None where the flag was not given."""
    fill: float = framing.FILL
    elevation: float | None = None
    azimuth: float = 0.0
    lens: float | None = None
    fov: float | None = None
    fps: float | None = None
    seconds: float | None = None

    def frame_count(self, fps: float) -> int | None:
        """--seconds in frames at `fps` (the scene's, or --fps)."""
        return None if self.seconds is None else _count(self.seconds, self.fps or fps)


def add_arguments(parser, render: bool = True) -> None:
    """--camera and the framing flags (values are read as text: checked by `read`).
    render: the command also takes a .blend (and --frames)."""
    only = "for a CAPTURE: " if render else ""
    parser.add_argument("--camera", metavar="VIEW|TRACK.json",
                        help=only + CAMERA_HELP.replace("ELEVATION", f"{framing.ELEVATION_DEG:g}"))
    parser.add_argument("--fill", metavar="FRACTION",
                        help=f"{only}how much of the frame's shorter side the capture spans in the "
                             f"widest frame of an orbit: the 2nd-98th percentile box of the centres of the "
                             f"splats that show (a faint, sparse halo round the subject does not count), "
                             f"{MIN_FILL:g}-{MAX_FILL:g} (default {framing.FILL:g})")
    parser.add_argument("--elevation", metavar="DEGREES",
                        help=f"{only}the camera's height above the capture's horizon, "
                             f"-{MAX_ELEVATION:g} to {MAX_ELEVATION:g} degrees (default "
                             f"{framing.ELEVATION_DEG:g} for orbit, 0 for the still views)")
    parser.add_argument("--azimuth", metavar="DEGREES",
                        help=f"{only}turn every view (and the orbit's start) this far counter-clockwise "
                             f"about the capture's up, seen from above, from where it would stand: "
                             f"180 when front shows the subject's back, -{MAX_AZIMUTH:g} to "
                             f"{MAX_AZIMUTH:g} (default 0)")
    lens = parser.add_argument_group("lens (" + ("for a CAPTURE; " if render else "") + "one of)")
    lens.add_argument("--lens", metavar="MM",
                      help=f"focal length on a 36 mm sensor, {MIN_LENS:g}-{MAX_LENS:g} (default 50)")
    lens.add_argument("--fov", metavar="DEGREES",
                      help=f"field of view across the frame's longer side, {MIN_FOV:g}-{MAX_FOV:g} "
                           f"(default 39.6, the 50 mm lens's)")
    parser.add_argument("--fps", metavar="N",
                        help=f"frames per second of the scene and its movie, {MIN_FPS}-{MAX_FPS} (fractions "
                             f"such as 29.97 allowed); default: " + ("the .blend's, " if render else "") +
                             f"a camera track's own, or "
                             f"{DEFAULT_FPS} for a capture")  # Blender's default, now said
    parser.add_argument("--seconds", metavar="S",
                        help="length in seconds" + (", instead of --frames" if render else "") +
                             ": frames 1 to round(S x fps)" + (" (from the scene's start frame for a "
                                                               ".blend)" if render else "") +
                             f"; an orbit's default is {DEFAULT_ORBIT_FRAMES} frames, "
                             f"{DEFAULT_ORBIT_FRAMES / DEFAULT_FPS:g} s at {DEFAULT_FPS} fps")


def read(args, for_blend: bool = False) -> Framing:
    """The flags of `args` checked (UsageError: one line, exit 2). for_blend: the input is a
    .blend, whose cameras stay its own: the capture-only flags are refused."""
    given = {name: getattr(args, name, None) for name in ("fill", "elevation", "azimuth", "lens", "fov")}
    if for_blend:
        for name, text in given.items():
            if text is not None:
                raise UsageError(f"--{name} {text}: applies to a capture, not to a .blend (it has its cameras)")
    if given["lens"] is not None and given["fov"] is not None:
        raise UsageError(f"--lens {given['lens']} --fov {given['fov']}: give one or the other")
    if args.seconds is not None and getattr(args, "frames", None):
        raise UsageError(f"--seconds {args.seconds} --frames {args.frames}: give one or the other")
    fill = number("--fill", given["fill"], MIN_FILL, MAX_FILL)
    options = Framing(
        fill=framing.FILL if fill is None else fill,
        elevation=number("--elevation", given["elevation"], -MAX_ELEVATION, MAX_ELEVATION),
        azimuth=number("--azimuth", given["azimuth"], -MAX_AZIMUTH, MAX_AZIMUTH) or 0.0,
        lens=number("--lens", given["lens"], MIN_LENS, MAX_LENS),
        fov=number("--fov", given["fov"], MIN_FOV, MAX_FOV),
        fps=number("--fps", args.fps, MIN_FPS, MAX_FPS),
        seconds=number("--seconds", args.seconds, 0.0, math.inf, low_open=True))
    if options.seconds is not None and options.fps is not None:
        options.frame_count(options.fps)  # too long for Blender: refused now
    return options


def number(flag, text, low, high, low_open=False):
    """An option's number within [low, high], or one line (UsageError) naming the option."""
    if text is None:
        return None
    try:
        value = float(text)
    except ValueError:
        raise UsageError(f"{flag} {text}: expected a number") from None
    if not math.isfinite(value) or value < low or value > high or (low_open and value <= low):
        span = (f"more than {low:g}" if high == math.inf else
                f"in {low:g} to {high:g}" if low < 0 else f"in {low:g}-{high:g}")
        raise UsageError(f"{flag} {text}: must be {span}")
    return value


def _count(seconds: float, fps: float) -> int:
    count = round(seconds * fps)
    if not 1 <= count <= MAX_FRAME:
        raise UsageError(f"--seconds {seconds:g}: {count} frames at {fps:g} fps; must be 1-{MAX_FRAME} "
                         f"(Blender's limit)")
    return count


def parse_frames(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"\s*(-?\d+)\s*(?:-\s*(-?\d+)\s*)?", text or "")
    if match is None:
        raise UsageError(f"--frames {text!r}: expected A-B or a single frame")
    start = int(match.group(1))
    end = int(match.group(2)) if match.group(2) is not None else start
    if end < start:
        raise UsageError(f"--frames {text!r}: the range ends before it starts")
    if start < 0 or end > MAX_FRAME:
        raise UsageError(f"--frames {text.strip()}: frames must lie in 0-{MAX_FRAME} (Blender's limit)")
    return start, end
