"""Ways to fill a 1920x1080 RenderResult pass from Python (issue 29: the render-result path
made as short as its API allows). A throwaway engine times, in CPU ms (median of 7):
the first foreach_set into the result Blender has just allocated (what a frame pays: the
pages are touched for the first time), then foreach_set of a flat contiguous float32 array
(the engine's way: a straight copy), and assigning the array to `rect` (element by element).

    python -m bench.render_result_fill_bench
"""
from __future__ import annotations

import time

import numpy as np

W, H = 1920, 1080


def _median_ms(fn, runs: int = 7) -> float:
    times = []
    for _ in range(runs):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return sorted(times)[runs // 2] * 1000


def main():
    import bpy

    got = {}

    class FillEngine(bpy.types.RenderEngine):
        bl_idname = "SPLATLINE_FILL_BENCH"
        bl_label = "fill bench"

        def render(self, depsgraph):
            result = self.begin_result(0, 0, W, H)
            rect = result.layers[0].passes.find_by_name("Combined", result.views[0].name).rect
            flat = np.random.default_rng(0).random(W * H * 4).astype(np.float32)
            t0 = time.process_time()
            rect.foreach_set(flat)
            got["foreach_set, fresh result (first touch)"] = (time.process_time() - t0) * 1000
            got["foreach_set, flat float32"] = _median_ms(lambda: rect.foreach_set(flat))
            pixels = flat.reshape(-1, 4)
            got["rect = (N, 4) float32"] = _median_ms(
                lambda: setattr(result.layers[0].passes[0], "rect", pixels), runs=3)
            back = np.empty_like(flat)
            rect.foreach_get(back)
            assert np.array_equal(back, flat), "foreach_set did not store the array"
            got["numpy copy of the same 33 MB"] = _median_ms(flat.copy)
            self.end_result(result)

    bpy.utils.register_class(FillEngine)
    try:
        scene = bpy.context.scene
        scene.render.engine = FillEngine.bl_idname
        scene.render.resolution_x, scene.render.resolution_y = W, H
        scene.render.resolution_percentage = 100
        bpy.ops.render.render()
    finally:
        bpy.utils.unregister_class(FillEngine)
    print(f"Filling a {W}x{H} RGBA RenderResult pass, CPU ms (median of 7; rect = of 3)")
    for name, ms in got.items():
        print(f"  {name}: {ms:.1f}")


if __name__ == "__main__":
    main()
