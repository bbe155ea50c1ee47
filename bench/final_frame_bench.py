"""Final frames on playbot-size data: the offscreen renderer at 1920x1080 on a generated
~500,000-splat degree-2 capture (bench/playbot_scene.py), now and before, in one run.

    python -m bench final        (or make bench)

Each row is one entry of ROWS. Columns:
- ms now / before: median wall ms per frame over RUNS frames after a warm-up on a small
  frame (shaders, uploads); CPU ms alongside (all threads: llvmpipe's included), which
  shared machines disturb less. "Before" is the renderer of BEFORE (the commit before
  issue 14's batching and Z pass: back-to-front single draw, search depth pass) taken
  from git into a temporary folder and run in a worker process on the same scene, its
  frames interleaved with this tree's so both see the same machine load.
- PSNR / max abs: premultiplied RGBA against the float64 reference (core/reference.py),
  with early termination (ET, INRIA's exact stop) and without it (the full composite).
  The reference is far too slow for the whole frame at this size, so the error is over
  TILES: five 128x128 windows of the frame (centre and four off-centre), rendered by the
  reference exactly as parts of the same frame (reference.render(window=...)).
- Z max err: the Z pass against the reference's (alpha-weighted depth, no ET), the
  largest error relative to the depth range of the tiles, over pixels with a depth in both.
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
from dataclasses import dataclass, replace

import numpy as np

from addon.core import reference
from addon.core.camera import Camera
from addon.core.scene import RenderOptions
from bench.playbot_scene import scene

RUNS = 3
SIZE = (1920, 1080)
COUNT = 500_000
BEFORE = "7bec52bdd58f941ff411b3d870945cc9e303fbe0"  # main before issue 14 (items 1, 2)
TILES = ((896, 476), (256, 160), (1536, 160), (256, 792), (1536, 792))
TILE = 128
REPO = pathlib.Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Row:
    """One row: how this tree renders it, and the baseline worker's name for the same
    frame (None: no before). camera maps the bench camera to the row's."""
    label: str
    options: RenderOptions = RenderOptions()
    depth: bool = False
    before: str | None = None
    camera: object = None


ROWS = (
    Row("colour", depth=False, before="colour"),
    Row("+ Z", depth=True, before="z"),
    # Issue 14 items 3-5 (branch f14camera) add one entry each here:
    # "+ DOF", "+ motion blur (8 samples)", "equirect".
)

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


class Before:
    """The BEFORE commit's renderer in a worker process (None where git can't give it)."""

    def __init__(self):
        self.proc = None
        self.dir = tempfile.TemporaryDirectory(prefix="splatline-before-")
        try:
            archive = subprocess.run(["git", "-C", str(REPO), "archive", BEFORE, "addon", "shaders"],
                                     capture_output=True, check=True).stdout
        except (OSError, subprocess.CalledProcessError) as exc:
            print(f"(no before column: git archive {BEFORE[:8]} failed: {exc})")
            return
        with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
            safe = {"filter": "data"} if hasattr(tarfile, "data_filter") else {}
            tar.extractall(self.dir.name, **safe)
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


def small_camera(cam: Camera) -> Camera:
    return Camera(cam.world_to_camera, 64, 36, cam.fx / 30, cam.fy / 30, 32.0, 18.0, cam.near, cam.far)


def psnr(a, b) -> float:
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return float("inf") if mse == 0 else 10.0 * np.log10(1.0 / mse)


def tile_errors(out, items, cam, options: RenderOptions) -> dict:
    """PSNR and max abs against the reference with and without ET, and the Z error."""
    got, refs = [], {True: [], False: []}
    for x, y in TILES:
        got.append(out.rgba[y:y + TILE, x:x + TILE])
        for early in (True, False):
            refs[early].append(reference.render(items, cam, replace(options, early_termination=early),
                                                window=(x, y, TILE, TILE)))
    rgba = np.concatenate(got)
    err = {}
    for early in (True, False):
        ref = np.concatenate([r.rgba for r in refs[early]])
        err[early] = (psnr(rgba, ref), float(np.abs(rgba - ref).max()))
    depth = np.concatenate([out.depth[y:y + TILE, x:x + TILE] for x, y in TILES])
    ref_depth = np.concatenate([r.depth for r in refs[False]])
    both = np.isfinite(depth) & np.isfinite(ref_depth)
    z_err = float("nan")
    if both.any() and np.isfinite(depth).any():
        span = float(ref_depth[both].max() - ref_depth[both].min())
        z_err = float(np.abs(depth[both] - ref_depth[both]).max()) / span
    return {"et": err[True], "full": err[False], "z": z_err,
            "saturated": float(np.mean(np.concatenate([r.rgba for r in refs[False]])[..., 3] > 1 - 1e-4))}


def main():
    from addon.gl import OffscreenRenderer

    start = time.perf_counter()
    items, cam = scene(COUNT, *SIZE)
    before = Before()
    now = {False: OffscreenRenderer(depth_pass=False), True: OffscreenRenderer()}
    try:
        print(f"GL: {now[False].gl_info.get('GL_RENDERER')}; {COUNT:,} splats, SH 2, {SIZE[0]}x{SIZE[1]}")
        for r in now.values():
            r.render(items, small_camera(cam), RenderOptions())
        times = {row.label: {"now": [], "before": []} for row in ROWS}
        outputs = {}
        for _ in range(RUNS):  # interleaved: before and now see the same load
            for row in ROWS:
                row_cam = row.camera(cam) if row.camera else cam
                if row.before:
                    t = before.frame(row.before)
                    if t is not None:
                        times[row.label]["before"].append(t)
                t, c = time.perf_counter(), time.process_time()
                outputs[row.label] = now[row.depth].render(items, row_cam, row.options)
                times[row.label]["now"].append((time.perf_counter() - t, time.process_time() - c))
        rows = []
        for row in ROWS:
            row_cam = row.camera(cam) if row.camera else cam
            rows.append((row, times[row.label], tile_errors(outputs[row.label], items, row_cam, row.options)))
    finally:
        before.close()
        for r in now.values():
            r.close()
    print_table(rows)
    print(f"\n(whole table: {time.perf_counter() - start:.0f} s; rerun: python -m bench final)")


def _ms(samples, which: int) -> float:
    return 1000.0 * statistics.median(s[which] for s in samples) if samples else float("nan")


def print_table(rows):
    print(f"\nfinal frames, ms = median of {RUNS} (wall; CPU of all threads in brackets); error over "
          f"{len(TILES)} {TILE}x{TILE} reference tiles")
    print(f"{'row':10s} {'ms now':>14s} {'ms before':>16s} {'now/before':>12s} {'PSNR ET':>8s} "
          f"{'PSNR full':>9s} {'max abs ET/full':>17s} {'Z max err':>9s}")
    colour_ms = colour_cpu = None
    for row, t, e in rows:
        now, before = _ms(t["now"], 0), _ms(t["before"], 0)
        now_cpu, before_cpu = _ms(t["now"], 1), _ms(t["before"], 1)
        if colour_ms is None:
            colour_ms, colour_cpu = now, now_cpu
        z = f"{e['z']:.1e}" if row.depth else "-"
        b = f"{before:.0f} ({before_cpu:.0f})" if t["before"] else "-"
        ratio = f"{now / before:.2f} ({now_cpu / before_cpu:.2f})" if t["before"] else "-"
        worst = f"{e['et'][1]:.1e}/{e['full'][1]:.1e}"
        print(f"{row.label:10s} {f'{now:.0f} ({now_cpu:.0f})':>14s} {b:>16s} {ratio:>12s} "
              f"{e['et'][0]:8.1f} {e['full'][0]:9.1f} {worst:>17s} {z:>9s}",
              flush=True)
    for row, t, e in rows[1:]:
        print(f"{row.label} / colour (now): {_ms(t['now'], 0) / colour_ms:.2f}x wall, "
              f"{_ms(t['now'], 1) / colour_cpu:.2f}x CPU")
    print(f"saturated pixels (T < 1e-4) in the tiles: {100 * rows[0][2]['saturated']:.0f}%")


if __name__ == "__main__":
    main()
