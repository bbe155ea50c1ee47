"""Final frames through the command line, the way issue 14 measured them: seconds per frame
of `python -m addon render` at 1920x1080, PNG and EXR (multilayer: Combined + Depth), now
and before (BEFORE: the code issue 29 measured against, taken from git), on a .blend holding the final-frame
bench's capture (bench/playbot_scene.py, written to a .ply and imported as one object with
the importer's axes) under the same camera.

    python -m bench.cli_frame_bench [runs] [--also NAME=TREE ...]

--also adds another checkout of the code (a worktree of an earlier commit, say) rendering
the same frames in the same run, for before/after tables of a change.
Goal (issue 29): <= 1/3 of BEFORE's time per frame, PNG and EXR (with Depth), printed as
met or MISSED.

Each render is a fresh process (Blender's pipeline, the engine, the film conversion and the
file writing included) rendering frames 1-3 (EXR before: 1-2, at ~28 s a frame); the first
frame of each, which makes the GL context and uploads the splats, is left out. Median over
the runs of the remaining frames; now and before take turns going first.
"""
from __future__ import annotations

import json
import pathlib
import re
import statistics
import subprocess
import sys
import tempfile

import numpy as np

from bench.final_frame_bench import COUNT, REPO, SIZE, extract_before
from bench.playbot_scene import scene

# Issue 29's baseline: the command line's frames as they were when it was filed (the
# renderer's own BEFORE, final_frame_bench.BEFORE, is older still).
BEFORE = "84fef8dd89ab9adabf3f3168c3e85a9fa89afc78"
FORMATS = {"PNG": ("1-3", "1-3"), "EXR": ("1-3", "1-2")}  # frames: (now, before)
GOAL = 1 / 3  # of before's seconds per frame (issue 29)
FRAME_LINE = re.compile(r"^frame (\d+) \(\d+/\d+\)\s+([0-9.]+) s", re.M)


def make_blend(folder: pathlib.Path) -> pathlib.Path:
    """The capture as one .ply, imported by the CLI, with the bench camera put in."""
    from addon.core.edit import merge
    from addon.core.formats.ply import write_ply

    items, cam = scene(COUNT, *SIZE)
    write_ply(folder / "playbot.ply", merge([item.splats for item in items]))
    blend = folder / "playbot.blend"
    subprocess.run([sys.executable, "-m", "addon", "import", str(folder / "playbot.ply"),
                    "--blend", str(blend), "--camera", "front"], cwd=REPO, check=True,
                   capture_output=True)
    subprocess.run([sys.executable, "-c", CAMERA, str(blend), json.dumps(cam.world_to_camera.tolist()),
                    str(2 * np.degrees(np.arctan(cam.width / (2 * cam.fx))))],
                   cwd=REPO, check=True, capture_output=True)
    return blend


# in a fresh process: bpy, the add-on registered (the .blend's object holds its data)
CAMERA = r"""
import json, math, sys
import bpy, mathutils
from addon import register
register()
path, world_to_camera, fov_x = sys.argv[1], json.loads(sys.argv[2]), float(sys.argv[3])
bpy.ops.wm.open_mainfile(filepath=path)
scene = bpy.context.scene
capture = next(o for o in scene.objects if o.type != "CAMERA")
camera = scene.camera
camera.animation_data_clear()
camera.matrix_world = capture.matrix_world @ mathutils.Matrix(world_to_camera).inverted()
camera.data.sensor_fit, camera.data.angle_x = "HORIZONTAL", math.radians(fov_x)
camera.data.clip_start, camera.data.clip_end = 0.05, 50.0
bpy.ops.wm.save_as_mainfile(filepath=path)
"""


def frame_seconds(tree: str, blend: pathlib.Path, fmt: str, frames: str, out: str) -> list[float]:
    """Seconds of each frame after the first, from the CLI's per-frame lines."""
    done = subprocess.run([sys.executable, "-m", "addon", "render", str(blend), "--frames", frames,
                           "--resolution", f"{SIZE[0]}x{SIZE[1]}", "--format", fmt, "--out", out],
                          cwd=tree, capture_output=True, text=True, check=True)
    times = [float(t) for _, t in FRAME_LINE.findall(done.stdout)]
    if len(times) < 2:
        raise RuntimeError(f"render printed {len(times)} frame lines:\n{done.stdout}\n{done.stderr}")
    return times[1:]


def main(runs: int = 2, also: dict | None = None):
    with tempfile.TemporaryDirectory(prefix="splatline-cli-bench-") as tmp:
        folder = pathlib.Path(tmp)
        blend = make_blend(folder)
        trees = {"now": str(REPO), **(also or {})}
        if extract_before(str(folder / "before"), BEFORE):
            trees["before"] = str(folder / "before")
        print(f"python -m addon render, {COUNT:,} splats, SH 2, {SIZE[0]}x{SIZE[1]}, "
              f"before = {BEFORE[:7]}; s per frame, median of the frames after the first, {runs} runs")
        for fmt, frames in FORMATS.items():
            got = {name: [] for name in trees}
            for run in range(runs):
                for name in (list(trees) if run % 2 == 0 else list(trees)[::-1]):
                    span = frames[1] if name == "before" else frames[0]
                    got[name] += frame_seconds(trees[name], blend, fmt, span, str(folder / name))
            median = {name: statistics.median(times) for name, times in got.items()}
            line = f"  {fmt}: " + ", ".join(f"{name} {t:.3f} s" for name, t in median.items())
            if "before" in median:
                line += "; " + ", ".join(f"{name} / before {t / median['before']:.2f}"
                                         for name, t in median.items() if name != "before")
                ratio = median["now"] / median["before"]
                line += f"; goal now <= {GOAL:.2f} x before: {'met' if ratio <= GOAL else 'MISSED'}"
            for name in also or {}:
                line += f"; now / {name} {median['now'] / median[name]:.2f}"
            print(line, flush=True)


def _arguments(argv: list[str]) -> tuple[int, dict]:
    runs, also = 2, {}
    args = iter(argv)
    for arg in args:
        if arg == "--also":
            name, _, tree = next(args, "").partition("=")
            if not tree or name in ("now", "before"):
                raise SystemExit("--also wants NAME=TREE (a checkout of the code; not now/before)")
            also[name] = str(pathlib.Path(tree).resolve())
        else:
            runs = int(arg)
    return runs, also


if __name__ == "__main__":
    main(*_arguments(sys.argv[1:]))
