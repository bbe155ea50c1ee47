"""Final frames on playbot-size data: the offscreen renderer at 1920x1080 on a generated
~500,000-splat degree-2 capture (bench/playbot_scene.py), now and before, in one run.

    python -m bench final        (or make bench)
    python -m bench.final_frame_bench colour [runs]   (the colour row's timing alone)

One row per entry of final_frame_rows.ROWS: colour, + Z, + DOF, + motion blur, equirect.
Columns:
- ms now / before: median wall ms per frame over RUNS frames after a warm-up on a small
  frame (shaders, uploads); CPU ms alongside (all threads: llvmpipe's included), which
  shared machines disturb less. A motion-blurred frame is all its sub-frame renders and
  their average. "Before" is the renderer of BEFORE (the commit before issue 14's
  batching and Z pass: back-to-front single draw, search depth pass) taken from git into a
  temporary folder and run in a worker process on the same scene, its frames interleaved
  with this tree's (which of the two goes first alternates run by run) so both see the
  same machine load; it has no DOF, motion blur or
  panorama ("n/a (new)"). now / colour: the row against this tree's colour row, same run.
- PSNR / max abs: premultiplied RGBA against the float64 reference (core/reference.py)
  with the same feature (motion blur: the same average of reference sub-frames), with
  early termination (ET, INRIA's exact stop) and without it (the full composite). The
  reference is far too slow for the whole frame at this size, so the error is over each
  row's windows (final_frame_rows: five 128x128 tiles; equirect: centre, seam, poles),
  rendered by the reference exactly as parts of the same frame (reference.render(window=...)),
  from the splats that reach them (common.reaching; the others add nothing there).
- Z max err: the Z pass against the reference's (alpha-weighted depth, no ET), the
  largest error relative to the depth range of the tiles, over pixels with a depth in both.
Under the table: DOF against the lens itself (final_frame_rows.lens_figures).
"""
from __future__ import annotations

import io
import json
import pathlib
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time

import numpy as np

from addon.core import reference, shutter
from addon.core.scene import RenderOptions
from bench.common import crop, psnr, reaching
from bench.final_frame_rows import LENS_SAMPLES, ROWS, lens_figures, small
from bench.playbot_scene import scene

RUNS = 3
SIZE = (1920, 1080)
COUNT = 500_000
BEFORE = "7bec52bdd58f941ff411b3d870945cc9e303fbe0"  # main before issue 14 (items 1, 2)
REPO = pathlib.Path(__file__).resolve().parents[1]
OPTIONS = RenderOptions()  # the renderer's defaults (early termination on)

WORKER = r"""
import json, sys, time
sys.path[:0] = [sys.argv[1], sys.argv[2]]   # the old tree first, then the repo (bench)
from addon.gl import OffscreenRenderer
from addon.core.camera import Camera
from addon.core.scene import RenderOptions
from bench.playbot_scene import scene
items, cam = scene(int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]))
small = Camera(cam.world_to_camera, 64, 36, cam.fx / 30, cam.fy / 30, 32.0, 18.0, cam.near, cam.far)
renderers = {"colour": OffscreenRenderer(depth_pass=False), "z": OffscreenRenderer()}
for r in renderers.values():
    r.render(items, small, RenderOptions())
print("ready", flush=True)
for line in sys.stdin:
    r = renderers[line.strip()]
    t, c = time.perf_counter(), time.process_time()
    r.render(items, cam, RenderOptions())
    print(json.dumps([time.perf_counter() - t, time.process_time() - c]), flush=True)
"""


def extract_before(folder: str, commit: str = BEFORE) -> bool:
    """commit's addon/ and shaders/ from git into folder; False (said) where git can't."""
    try:
        archive = subprocess.run(["git", "-C", str(REPO), "archive", commit, "addon", "shaders"],
                                 capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError) as exc:
        print(f"(no before column: git archive {commit[:8]} failed: {exc})")
        return False
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        safe = {"filter": "data"} if hasattr(tarfile, "data_filter") else {}
        tar.extractall(folder, **safe)
    return True


class Before:
    """The BEFORE commit's renderer in a worker process (None where git can't give it)."""

    def __init__(self):
        self.proc = None
        self.dir = tempfile.TemporaryDirectory(prefix="splatline-before-")
        if not extract_before(self.dir.name):
            return
        self.proc = subprocess.Popen(
            [sys.executable, "-c", WORKER, self.dir.name, str(REPO), str(COUNT), *map(str, SIZE)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        assert self.proc.stdout.readline().strip() == "ready"

    def frame(self, kind: str):
        if self.proc is None:
            return None
        self.proc.stdin.write(kind + "\n")
        self.proc.stdin.flush()
        return json.loads(self.proc.stdout.readline())

    def close(self):
        if self.proc is not None:
            self.proc.stdin.close()
            self.proc.wait()
        self.dir.cleanup()


def render_row(renderer, states):
    """(rgba, depth or None) of one frame: the render, or the sub-frames' average."""
    if len(states) == 1:
        out = renderer.render(*states[0], OPTIONS)
        return out.rgba, out.depth
    avg = shutter.Average(len(states))
    for items, cam in states:
        avg.add(renderer.render(items, cam, OPTIONS).rgba)
    return avg.result(), None


def tile_errors(rgba, depth, states, windows) -> dict:
    """PSNR and max abs against the reference (averaged like the frame) with and without
    ET over the windows, the Z error (one state only), the saturated share."""
    refs, ref_depth = {True: [], False: []}, []
    for win in windows:
        cut = [(reaching(items, cam, win), cam) for items, cam in states]
        for early in (True, False):
            avg = shutter.Average(len(cut))
            for items, cam in cut:
                out = reference.render(items, cam, RenderOptions(early_termination=early), window=win)
                avg.add(out.rgba)
            refs[early].append(avg.result().reshape(-1, 4))
        ref_depth.append(out.depth.reshape(-1))  # the last state's, without ET
    got = np.concatenate([crop(rgba, w).reshape(-1, 4) for w in windows]).astype(np.float64)
    err = {}
    for early in (True, False):
        ref = np.concatenate(refs[early])
        err["et" if early else "full"] = (psnr(got, ref), float(np.abs(got - ref).max()))
    err["windows"] = [(psnr(g, r), float(np.abs(g - r).max())) for g, r in zip(
        np.split(got, np.cumsum([w[2] * w[3] for w in windows])[:-1]), refs[False])]
    err["saturated"] = float(np.mean(np.concatenate(refs[False])[:, 3] > 1 - 1e-4))
    err["z"] = float("nan")
    if depth is not None and len(states) == 1:
        z = np.concatenate([crop(depth, w).reshape(-1) for w in windows])
        ref_z = np.concatenate(ref_depth)
        both = np.isfinite(z) & np.isfinite(ref_z)
        if both.any():
            span = float(ref_z[both].max() - ref_z[both].min())
            err["z"] = float(np.abs(z[both] - ref_z[both]).max()) / span
    return err


def timed_frames(before, now: dict, states: dict, rows=ROWS, runs: int = RUNS):
    """`runs` frames of every row, interleaved so that before and now see the same load,
    the two taking turns going first (the first of two frames tends to be slower): (times
    per row, this tree's last frame per row)."""
    times = {row.label: {"now": [], "before": []} for row in rows}
    frames = {}

    def time_before(row):
        t = before.frame(row.before) if row.before else None
        if t is not None:
            times[row.label]["before"].append(t)

    def time_now(row):
        t, c = time.perf_counter(), time.process_time()
        frames[row.label] = render_row(now[row.depth], states[row.label])
        times[row.label]["now"].append((time.perf_counter() - t, time.process_time() - c))

    for run in range(runs):
        for row in rows:
            for step in ((time_before, time_now) if run % 2 == 0 else (time_now, time_before)):
                step(row)
    return times, frames


def main():
    from addon.gl import OffscreenRenderer

    start = time.perf_counter()
    items, cam = scene(COUNT, *SIZE)
    states = {row.label: row.states(items, cam) for row in ROWS}
    before = Before()
    now = {False: OffscreenRenderer(depth_pass=False), True: OffscreenRenderer()}
    try:
        print(f"GL: {now[False].gl_info.get('GL_RENDERER')}; {COUNT:,} splats, SH 2, {SIZE[0]}x{SIZE[1]}")
        for row in ROWS:
            s_items, s_cam = states[row.label][0]
            now[row.depth].render(s_items, small(s_cam), OPTIONS)
        times, frames = timed_frames(before, now, states)
    finally:
        before.close()
        for r in now.values():
            r.close()
    rows = []
    for row in ROWS:
        rows.append((row, times[row.label], tile_errors(*frames[row.label], states[row.label], row.windows)))
    print_table(rows)
    lens = lens_figures(frames["+ DOF"][0], items, cam)
    x, y, w, h = lens["window"]
    print(f"+ DOF against the lens itself (mean of {LENS_SAMPLES} exact pinhole renders over the aperture), "
          f"{w}x{h} crop at ({x}, {y}), the arm's edge on the far wall: "
          + "; ".join(f"{k} {v[0]:.1f} dB, max {v[1]:.1e}" for k, v in lens.items() if k != "window"))
    print(f"\n(whole table: {time.perf_counter() - start:.0f} s; rerun: python -m bench final)")


def _ms(samples, which: int) -> float:
    return 1000.0 * statistics.median(s[which] for s in samples) if samples else float("nan")


def print_table(rows):
    print(f"\nfinal frames, ms = median of {RUNS} (wall; CPU of all threads in brackets); error over "
          f"each row's reference windows (TILES: five 128x128; equirect: centre, seam, poles, one more)")
    print(f"{'row':28s} {'ms now':>13s} {'ms before':>14s} {'now/before':>12s} {'now/colour':>11s} "
          f"{'PSNR ET':>8s} {'PSNR full':>9s} {'max abs ET/full':>17s} {'Z max err':>9s}")
    colour = None
    for row, t, e in rows:
        now, now_cpu = _ms(t["now"], 0), _ms(t["now"], 1)
        colour = colour or (now, now_cpu)
        if t["before"]:
            before, before_cpu = _ms(t["before"], 0), _ms(t["before"], 1)
            b, ratio = f"{before:.0f} ({before_cpu:.0f})", f"{now / before:.2f} ({now_cpu / before_cpu:.2f})"
        else:
            b, ratio = ("n/a (new)", "-") if row.before is None else ("-", "-")
        z = f"{e['z']:.1e}" if row.depth else "-"
        worst = f"{e['et'][1]:.1e}/{e['full'][1]:.1e}"
        print(f"{row.label:28s} {f'{now:.0f} ({now_cpu:.0f})':>13s} {b:>14s} {ratio:>12s} "
              f"{f'{now / colour[0]:.2f} ({now_cpu / colour[1]:.2f})':>11s} "
              f"{e['et'][0]:8.1f} {e['full'][0]:9.1f} {worst:>17s} {z:>9s}", flush=True)
    print(f"saturated pixels (T < 1e-4) in the colour row's tiles: {100 * rows[0][2]['saturated']:.0f}%")
    for row, _, e in rows:
        if row.window_names:
            print(f"{row.label} per window, PSNR / max abs against the reference without ET: " + "; ".join(
                f"{n} {p:.1f} dB / {m:.1e}" for n, (p, m) in zip(row.window_names, e["windows"])))


def colour_only(runs: int):
    """The colour row's now / before alone, over more frames than the table's (its error
    columns left out): python -m bench.final_frame_bench colour [runs]."""
    from addon.gl import OffscreenRenderer

    items, cam = scene(COUNT, *SIZE)
    row = ROWS[0]
    states = {row.label: row.states(items, cam)}
    before = Before()
    now = {False: OffscreenRenderer(depth_pass=False)}
    try:
        now[False].render(items, small(cam), OPTIONS)
        times = timed_frames(before, now, states, (row,), runs)[0][row.label]
    finally:
        before.close()
        now[False].close()
    if not times["before"]:
        return
    ratios = [n[0] / b[0] for n, b in zip(times["now"], times["before"])]
    print(f"colour, {runs} frames each: now {_ms(times['now'], 0):.0f} ({_ms(times['now'], 1):.0f}) ms, "
          f"before {_ms(times['before'], 0):.0f} ({_ms(times['before'], 1):.0f}) ms; now / before "
          f"{_ms(times['now'], 0) / _ms(times['before'], 0):.3f} wall, "
          f"{_ms(times['now'], 1) / _ms(times['before'], 1):.3f} CPU (medians); "
          f"frame by frame {min(ratios):.3f}-{max(ratios):.3f} wall")


if __name__ == "__main__":
    if sys.argv[1:2] == ["colour"]:
        colour_only(int(sys.argv[2]) if len(sys.argv) > 2 else 8)
    else:
        main()
