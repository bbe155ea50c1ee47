"""The engine's conversion of a final frame into Blender's Combined rect (issue 29: the
part of a frame that is not the renderer): a 1920x1080 frame of the final-frame bench's
capture (bench/playbot_scene.py, the offscreen renderer), converted the way the engine did
before (whole-frame steps: premultiplied_srgb_to_linear, composite_over, bottom_up) and the
way it does now (film.result_rect, block by block), same frame, same run, checked bit for bit.

    python -m bench.film_convert_bench [runs]

CPU ms and wall ms, medians of runs (default 9); the two take turns.
"""
from __future__ import annotations

import sys
import time

import numpy as np

from addon.blender.render.film import bottom_up, result_rect
from addon.core.colorspace import composite_over, premultiplied_srgb_to_linear
from addon.core.scene import RenderOptions
from bench.final_frame_bench import COUNT, SIZE
from bench.playbot_scene import scene

WORLDS = {"film transparent": None, "black world": (0.0, 0.0, 0.0), "grey world": (0.05, 0.05, 0.05)}


def whole_frame(rgba, world):
    linear = premultiplied_srgb_to_linear(rgba)
    return bottom_up(composite_over(linear, world) if world is not None else linear)


def main(runs: int = 9):
    from addon.gl import OffscreenRenderer

    items, cam = scene(COUNT, *SIZE)
    with OffscreenRenderer(depth_pass=False) as renderer:
        rgba = renderer.render(items, cam, RenderOptions()).rgba
    print(f"Film -> Combined rect, {SIZE[0]}x{SIZE[1]}, {COUNT:,}-splat frame; ms, median of {runs}")
    for label, world in WORLDS.items():
        ways = {"whole-frame": lambda: whole_frame(rgba, world), "result_rect": lambda: result_rect(rgba, world)}
        a, b = (fn() for fn in ways.values())
        assert np.array_equal(a.view(np.uint32), b.view(np.uint32)), f"{label}: not bit for bit"
        got = {name: ([], []) for name in ways}
        for run in range(runs):
            for name in (list(ways) if run % 2 == 0 else list(ways)[::-1]):
                t, c = time.perf_counter(), time.process_time()
                ways[name]()
                got[name][1].append(1000 * (time.process_time() - c))
                got[name][0].append(1000 * (time.perf_counter() - t))
        (w0, c0), (w1, c1) = ((np.median(w), np.median(c)) for w, c in got.values())
        print(f"  {label}: whole-frame CPU {c0:.1f} (wall {w0:.1f}), result_rect CPU {c1:.1f} "
              f"(wall {w1:.1f}); CPU ratio {c1 / c0:.2f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 9)
