"""Sequence playback: the cost of stepping a splat sequence one frame (scene.frame_set plus
evaluate.collect_items) with and without the frame cache and the read-ahead thread.

    python -m bench sequence

Frames: FRAMES PLYs of COUNT splats with degree-3 SH, written to a temporary folder.
Rows (medians over the frames of RUNS passes; the first frame of each pass is excluded since
nothing can have read it ahead):
- decode only: formats.read of one frame, the baseline every row is compared with
- cold: cache budget 0 and no read-ahead, so every step decodes its frame synchronously
- read-ahead: 4 frames ahead, with WORK_S of other work (standing in for drawing) between
  steps, during which the background thread decodes the next frames
- cached: a second pass with every frame already in the (large enough) cache
"""
from __future__ import annotations

import os
import statistics
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FRAMES = 8
COUNT = 100_000
WORK_S = 0.08
RUNS = 3


def _step_times(bpy, collect_items, frames, work_s=0.0):
    times = []
    for f in frames:
        t0 = time.perf_counter()
        bpy.context.scene.frame_set(f)
        collect_items(bpy.context.evaluated_depsgraph_get())
        times.append(time.perf_counter() - t0)
        if work_s:
            time.sleep(work_s)
    return times[1:]


def main() -> None:
    sys.path.insert(0, ROOT)
    import bpy

    from addon import register
    from addon.blender.data import sequence_source
    from addon.blender.evaluate.items import collect_items
    from addon.blender.data.sequences import import_sequence
    from addon.core.formats import read, write
    from testing.synth import random_splats

    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy.types.Object, "splatline"):
        register()
    frames = list(range(1, FRAMES + 1))
    with tempfile.TemporaryDirectory() as tmp:
        paths = [os.path.join(tmp, f"frame_{f:04d}.ply") for f in frames]
        for i, path in enumerate(paths):
            write(path, random_splats(COUNT, degree=3, seed=i))
        decode = []
        for path in paths:
            t0 = time.perf_counter()
            read(path)
            decode.append(time.perf_counter() - t0)
        obj = import_sequence(bpy.context, tmp)
        seq = obj.splatline.sequence
        rows = [("decode only (formats.read)", decode[1:])]

        cold, ahead, cached = [], [], []
        for _ in range(RUNS):  # each run starts from an empty cache
            sequence_source.shutdown()
            seq.cache_budget_mb, seq.read_ahead = 0, 0
            cold += _step_times(bpy, collect_items, frames)
            sequence_source.shutdown()
            seq.cache_budget_mb, seq.read_ahead = 512, 4
            ahead += _step_times(bpy, collect_items, frames, WORK_S)
            cached += _step_times(bpy, collect_items, frames)
        sequence_source.shutdown()
        rows += [("cold: budget 0, no read-ahead", cold),
                 (f"read-ahead 4, {WORK_S * 1000:.0f} ms work between steps", ahead),
                 ("cached: second pass", cached)]

    base = statistics.median(rows[0][1])
    print(f"{FRAMES} frames x {COUNT} splats, degree 3 ({COUNT * 248 / 1e6:.1f} MB per PLY), "
          f"{RUNS} passes")
    print(f"{'case':48s} {'median ms/frame':>16s} {'vs decode':>10s}")
    for label, times in rows:
        med = statistics.median(times)
        print(f"{label:48s} {med * 1000:16.2f} {med / base:10.2f}")


if __name__ == "__main__":
    main()
