"""Where a final colour frame's fragments go on this GL (issue 14's llvmpipe goal): the
playbot frame of final_frame_bench (500k splats, SH 2, 1920x1080), counted splat by splat.

    python -m bench.fragment_census

Per early-termination batch: the splats with fragments (the others were culled by the
saturation map, or cover no pixel centre), the fragments rasterised, those at alpha >=
1/255 and, of those, the useful ones: landing on a pixel still at T >= 1e-4 when they
arrive, the only ones the reference's exact early termination keeps (read with
GL_EXT_shader_framebuffer_fetch; without it that column is left out). Then the drawn
splats that add nothing under exact early termination, with their fragments: what a
per-pixel stop could skip that the batch's map cannot.

One counting frame, from copies of the draw shaders with atomic counters patched in
(bench/shader_patch.py), on the compute path (no depth marks: every rasterised fragment
is shaded).
"""
from __future__ import annotations

import numpy as np

from addon.core.scene import RenderOptions
from addon.gl import composite
from bench.final_frame_bench import COUNT, SIZE
from bench.playbot_scene import scene
from bench.shader_patch import FETCH, KEEP, F, V, has_fetch, renderer_for

B_COUNTERS = 9  # storage binding of the counters (the sort's bindings are rebound per draw)
FIELDS = ("rasterised", "kept", "useful")  # counters per splat, in front-to-back rank order


def counting_edits(fetch: bool) -> list:
    """Shader edits counting, per front-to-back rank, fragments rasterised, at alpha >=
    1/255, and (with fetch) those at alpha >= 1/255 on a pixel not yet saturated."""
    block = f"layout(std430, binding = {B_COUNTERS}) buffer Counters {{ uint counters[]; }};\n"
    useful = ("    if (alpha >= SL_ALPHA_MIN && frag.a <= 1.0 - 1.0e-4) atomicAdd(counters[3u * v_rank + 2u], 1u);\n"
              if fetch else "")
    count = ("    atomicAdd(counters[3u * v_rank], 1u);\n"
             "    if (alpha >= SL_ALPHA_MIN) atomicAdd(counters[3u * v_rank + 1u], 1u);\n" + useful)
    out = "layout(location = 0) out vec4 frag;"
    edits = [(V, "flat out float v_depth;", "flat out float v_depth;\nflat out uint v_rank;"),
             (V, "    v_depth = r1.z;", "    v_depth = r1.z;\n    v_rank = u_first + uint(gl_InstanceID);"),
             (F, "flat in float v_depth;", "flat in float v_depth;\nflat in uint v_rank;\n" + block),
             (F, out, out.replace(" out ", " inout ") if fetch else out),
             (F, KEEP, count + KEEP)]
    if fetch:
        edits.append((F, "#version 430\n", "#version 430\n" + FETCH))
    return edits


def counting_frame(items, cam, fetch: bool) -> np.ndarray:
    """(visible, 3) int64 counters per front-to-back rank from one counting frame."""
    import moderngl

    r = renderer_for(counting_edits(fetch), items, cam)
    size = 4 * len(FIELDS) * sum(item.splats.count for item in items)
    buf = r._worker.call(lambda: r._worker.ctx.buffer(np.zeros(size, np.uint32).tobytes()))
    plain = moderngl.VertexArray.render

    def render(vao, *args, **kwargs):
        if kwargs.get("instances", -1) > 1:
            buf.bind_to_storage_buffer(B_COUNTERS)
        return plain(vao, *args, **kwargs)
    moderngl.VertexArray.render = render
    try:
        r.render(items, cam, RenderOptions())
        visible = r._worker.call(lambda: r._state.last[1])
        # the fragment stage's atomics are not tracked as writes: finish before reading
        raw = r._worker.call(lambda: (r._worker.ctx.finish(), buf.read(size=4 * len(FIELDS) * visible))[1])
    finally:
        moderngl.VertexArray.render = plain
        r._worker.call(buf.release)
        r.close()
    return np.frombuffer(raw, np.uint32).reshape(-1, 3).astype(np.int64)


def census(items, cam) -> dict:
    """Per-rank counts: rasterised, kept, useful (-1: no fetch)."""
    fetch = has_fetch(items, cam)
    counts = counting_frame(items, cam, fetch)
    return {"rasterised": counts[:, 0], "kept": counts[:, 1],
            "useful": counts[:, 2] if fetch else np.full(len(counts), -1)}


def print_census(counts: dict):
    m = lambda x: f"{x / 1e6:6.1f} M"  # noqa: E731
    ras, kept, useful = (counts[k] for k in ("rasterised", "kept", "useful"))
    fetch = useful.min(initial=0) >= 0
    print("batch: splats (with fragments) | fragments rasterised, alpha >= 1/255"
          + (", useful (exact ET)" if fetch else ""))
    for first, count in composite.batches(len(ras), True):
        part = slice(first, first + count)
        print(f"  {count:7d} ({int((ras[part] > 0).sum()):7d}) | {m(ras[part].sum())} "
              f"{m(kept[part].sum())}" + (f" {m(useful[part].sum())}" if fetch else ""))
    print(f"  all {len(ras):7d} ({int((ras > 0).sum()):7d}) | {m(ras.sum())} {m(kept.sum())}"
          + (f" {m(useful.sum())}" if fetch else ""))
    if fetch:
        drawn = ras > 0
        idle = drawn & (useful == 0)
        print(f"drawn splats adding nothing under exact early termination: {int(idle.sum()):,} of "
              f"{int(drawn.sum()):,}, with {m(ras[idle].sum()).strip()} of the fragments rasterised")


def main():
    items, cam = scene(COUNT, *SIZE)
    print(f"colour frame, {COUNT:,} splats, {SIZE[0]}x{SIZE[1]}, the renderer's batches")
    print_census(census(items, cam))


if __name__ == "__main__":
    main()
