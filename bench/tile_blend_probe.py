"""Would a tile-binned compute rasteriser beat the raster path on llvmpipe? A probe, not a
renderer: the playbot frame of final_frame_bench (500k splats, SH 2, 1920x1080, colour)
composited the way the CUDA rasterisers do, against the renderer as it is, in one run.

    python -m bench tile            (python -m bench.tile_blend_probe RUNS for more runs)

The probe takes the renderer's own preprocessed records and sort (frame.py), bins every
splat into the 16x16-pixel tiles its 1/255 ellipse box touches (numpy: a stable sort of
tile ids keeps each tile's list in depth order), and runs one compute workgroup per tile:
each pixel walks its tile's list front to back and stops exactly where the reference
does (the splat that would take T below 1e-4 is left out). A subgroup (8 lanes on
llvmpipe) loads as many list entries at once and broadcasts them one by one
(GL_ARB_shader_ballot), since on Mesa 22.3 a per-lane buffer load costs about what the
whole alpha-and-blend arithmetic does. A GL without that extension prints why and skips.

Rows: median wall ms of the probe's stages and of the renderer's whole frame (interleaved),
then the probe's PSNR against the renderer without early termination, with and without
its own stop, and the mean number of list entries a pixel walks before it stops.
"""
from __future__ import annotations

import statistics
import sys
import time

import numpy as np

from addon.core.preprocess import extent_sigmas
from addon.core.scene import RenderOptions
from addon.gl import OffscreenRenderer, shaders
from bench.common import cell_blocks, psnr
from bench.final_frame_bench import COUNT, SIZE
from bench.playbot_scene import scene

TILE = 16
BLEND = """
layout(local_size_x = TILE, local_size_y = TILE) in;
layout(std430, binding = 3) readonly buffer Rec0 { vec4 rec0[]; };
layout(std430, binding = 4) readonly buffer Rec1 { vec4 rec1[]; };
layout(std430, binding = 5) readonly buffer Rec2 { vec4 rec2[]; };
layout(std430, binding = 10) readonly buffer Ranges { uint ranges[]; };
layout(std430, binding = 11) readonly buffer Lists { uint lists[]; };
layout(std430, binding = 12) writeonly buffer Out { vec4 result[]; };
uniform uvec2 u_size;
uniform uint u_tiles_x;
uniform bool u_stop;
void main()
{
    uvec2 p = gl_GlobalInvocationID.xy;
    vec2 pix = vec2(p) + 0.5;
    uint tile = gl_WorkGroupID.y * u_tiles_x + gl_WorkGroupID.x;
    uint lo = ranges[tile], hi = ranges[tile + 1u], walked = 0u;
    float T = 1.0, T_end = 1.0;
    vec3 C = vec3(0.0);
    bool live = true;
    for (uint base = lo; base < hi; base += LANES) {
        vec4 a8 = vec4(0.0), b8 = vec4(0.0), c8 = vec4(0.0);
        if (base + gl_SubGroupInvocationARB < hi) {
            uint s = lists[base + gl_SubGroupInvocationARB];
            a8 = rec0[s]; b8 = rec1[s]; c8 = rec2[s];
        }
        uint m = min(LANES, hi - base);
        for (uint j = 0u; j < LANES; j++) {  // constant trip count: 1.5 s here, 2.8 s bounded by gl_SubGroupSizeARB
            if (j >= m) break;
            vec4 a = readInvocationARB(a8, j);
            vec2 b = readInvocationARB(b8.xw, j);
            float alpha = sl_alpha(pix - a.xy, vec3(a.zw, b.x), b.y);
            walked += live ? 1u : 0u;
            if (alpha >= SL_ALPHA_MIN) {
                if (u_stop && T * (1.0 - alpha) < 1.0e-4 && live) { live = false; T_end = T; T = 0.0; }
                C += T * alpha * readInvocationARB(c8, j).rgb;
                T *= 1.0 - alpha;
            }
        }
        if (allInvocationsARB(!live)) break;
    }
    if (live) T_end = T;
    if (p.x < u_size.x && p.y < u_size.y) {
        uint o = p.y * u_size.x + p.x;
        result[o] = vec4(C, 1.0 - T_end);
        result[u_size.x * u_size.y + o] = vec4(float(walked));
    }
}
"""
SUBGROUP_SIZE = """#version 430
#extension GL_ARB_shader_ballot : require
layout(local_size_x = 64) in;
layout(std430, binding = 0) writeonly buffer Out { uint size; };
void main() { if (gl_LocalInvocationIndex == 0u) size = gl_SubGroupSizeARB; }
"""


def bin_tiles(rec0, rec1, front_to_back, width, height):
    """Per-tile lists of record indices in depth order, and each tile's [start, end)."""
    cx, cy, a, b = rec0[front_to_back].T.astype(np.float64)
    c, radius, _, opacity = rec1[front_to_back].T.astype(np.float64)
    det = a * c - b * b
    k = extent_sigmas(opacity)
    with np.errstate(all="ignore"):
        ok = det > 1e-3 * a * c
        ex = np.where(ok, np.minimum(radius, k * np.sqrt(c / det) * 1.001 + 1e-3), radius)
        ey = np.where(ok, np.minimum(radius, k * np.sqrt(a / det) * 1.001 + 1e-3), radius)
    tiles_x, tiles_y = -(-width // TILE), -(-height // TILE)
    x0 = np.clip(np.ceil(cx - ex - 0.5), 0, width).astype(np.int64) // TILE
    x1 = np.clip(np.floor(cx + ex - 0.5), -1, width - 1).astype(np.int64)
    y0 = np.clip(np.ceil(cy - ey - 0.5), 0, height).astype(np.int64) // TILE
    y1 = np.clip(np.floor(cy + ey - 0.5), -1, height - 1).astype(np.int64)
    nx = np.where(x1 >= 0, x1 // TILE - x0 + 1, 0).clip(0)
    ny = np.where(y1 >= 0, y1 // TILE - y0 + 1, 0).clip(0)
    splat, column, row = cell_blocks(x0, y0, nx, ny)
    tile = row * tiles_x + column
    order = np.argsort(tile.astype(np.uint16 if tiles_x * tiles_y < 65536 else np.uint32), kind="stable")
    ranges = np.zeros(tiles_x * tiles_y + 1, np.uint32)
    ranges[1:] = np.cumsum(np.bincount(tile, minlength=tiles_x * tiles_y))
    return front_to_back[splat[order]].astype(np.uint32), ranges, tiles_x, tiles_y


class Probe:
    def __init__(self, renderer: OffscreenRenderer):
        self.r, self.ctx = renderer, renderer._worker.ctx
        head = "#version 430\n#extension GL_ARB_shader_ballot : require\n" \
               "#extension GL_ARB_shader_group_vote : require\n" f"#define TILE {TILE}u\n" \
               f"#define LANES {renderer._worker.call(self._subgroup_size)}u\n"
        self.cs = renderer._worker.call(self.ctx.compute_shader, head + shaders.read(shaders.MATH) + BLEND)
        self.buffers = []

    def _subgroup_size(self) -> int:
        cs = self.ctx.compute_shader(SUBGROUP_SIZE)
        out = self.ctx.buffer(reserve=4)
        out.bind_to_storage_buffer(0)
        cs.run(1)
        size = int(np.frombuffer(out.read(), np.uint32)[0])
        out.release()
        cs.release()
        return size

    def frame(self, items, cam, stop: bool = True) -> tuple[np.ndarray, np.ndarray, dict]:
        return self.r._worker.call(self._frame, items, cam, stop)

    def _frame(self, items, cam, stop):
        state, ctx, w, h, t = self.r._state, self.ctx, cam.width, cam.height, {}
        start = time.perf_counter()
        order, visible, n = state._gpu_prepare(items, cam, RenderOptions())
        front = np.frombuffer(order.read(size=4 * visible), np.uint32)[::-1].copy()
        rec = {k: np.frombuffer(state.arrays[k].read(size=16 * n), np.float32).reshape(n, 4)
               for k in ("rec0", "rec1")}
        t["preprocess and sort"] = time.perf_counter() - start
        start = time.perf_counter()
        lists, ranges, tiles_x, tiles_y = bin_tiles(rec["rec0"], rec["rec1"], front, w, h)
        t["binning (numpy)"] = time.perf_counter() - start
        start = time.perf_counter()
        for buf in self.buffers:
            buf.release()
        self.buffers = [ctx.buffer(ranges.tobytes()), ctx.buffer(lists.tobytes()),
                        ctx.buffer(reserve=2 * 16 * w * h)]
        for binding, buf in zip((10, 11, 12), self.buffers):
            buf.bind_to_storage_buffer(binding)
        for binding, name in ((3, "rec0"), (4, "rec1"), (5, "rec2")):
            state.arrays[name].bind_to_storage_buffer(binding)
        self.cs["u_size"], self.cs["u_tiles_x"], self.cs["u_stop"] = (w, h), tiles_x, stop
        self.cs.run(tiles_x, tiles_y)
        out = np.frombuffer(self.buffers[2].read(), np.float32).reshape(2, h, w, 4)
        t["blend (compute)"] = time.perf_counter() - start
        return out[0].copy(), out[1, ..., 0].copy(), t


def main(runs: int = 3):
    items, cam = scene(COUNT, *SIZE)
    r = OffscreenRenderer(depth_pass=False)
    try:
        extensions = r._worker.call(lambda: set(r._worker.ctx.extensions))
        missing = {"GL_ARB_shader_ballot", "GL_ARB_shader_group_vote"} - extensions
        if not r.uses_compute or missing:
            print(f"tile-binned compute probe skipped: this GL lacks {sorted(missing) or 'compute shaders'}")
            return
        probe = Probe(r)
        full = r.render(items, cam, RenderOptions(early_termination=False)).rgba
        samples = []
        for _ in range(runs):
            start = time.perf_counter()
            r.render(items, cam, RenderOptions())
            raster = time.perf_counter() - start
            start = time.perf_counter()
            rgba, walked, stages = probe.frame(items, cam)
            samples.append({**stages, "probe frame": time.perf_counter() - start, "raster frame (renderer)": raster})
        no_stop, _, _ = probe.frame(items, cam, stop=False)
    finally:
        r.close()
    print(f"tile-binned compute probe, {COUNT:,} splats, {SIZE[0]}x{SIZE[1]}, {TILE}x{TILE} tiles: "
          f"median wall ms of {runs}")
    for key in samples[0]:
        print(f"  {key:26s} {1000 * statistics.median(s[key] for s in samples):7.0f}")
    print(f"  PSNR against the renderer without early termination: probe without a stop "
          f"{psnr(no_stop, full):.1f} dB, with its exact stop {psnr(rgba, full):.1f} dB")
    print(f"  list entries a pixel walks before it stops: {walked.mean():.0f} (mean)")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
