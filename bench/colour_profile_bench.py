"""Where a final colour frame's time goes on this GL (issue 14's llvmpipe goal): the
playbot frame of final_frame_bench (500k splats, SH 2, 1920x1080, colour only) drawn by
instrumented copies of the draw shaders, each knocking out one part of the work.

    python -m bench.colour_profile_bench [runs]

Rows (median CPU of all threads and wall over the runs, frames interleaved, each run
starting at the next row):
- full: the renderer as it is.
- no raster: the vertex stage runs (records, rectangle, saturation test) but puts every
  quad outside the clip volume; what is left is upload, preprocess, sort, the marking
  and saturation-map passes and the readback.
- no vertex work: as above, but the vertex stage returns before reading anything.
- no ET passes: "no vertex work" without early termination (no mark or map passes).
- 1 px quads: every drawn quad shrunk to about one pixel: the per-primitive cost.
- all rejected: after the first batch the mark pass marks every pixel, so all later
  fragments fail the early depth test: the cost of a depth-rejected fragment.
- ET off: the full composite.
- ten batches: the batch schedule before commit 4d5c3c9, doubling from 1/64 of the splats
  to 1/8 (ten marking passes where the renderer's now makes three).
Then the share of the frame's 4x4-pixel cells saturated at each marking pass, with the
renderer's batches and with ten, and counts from one counting frame (atomic counters,
framebuffer fetch where the GL has GL_EXT_shader_framebuffer_fetch): fragments past the
depth test, those at alpha >= 1/255, and of those the ones landing on a pixel already at
T < 1e-4 (batch-granular ET's excess).
The instrumented copies are this bench's only: it patches the shader text it loads.
"""
from __future__ import annotations

import statistics
import sys
import time

import numpy as np

from addon.core.scene import RenderOptions
from addon.gl import composite, shaders
from bench.final_frame_bench import COUNT, SIZE
from bench.final_frame_rows import small as small_camera
from bench.playbot_scene import scene

V, F, MARK = "gl_splat.vert", "gl_splat.frag", "gl_saturate.frag"
OUTSIDE = "gl_Position = vec4(2.0, 2.0, 2.0, 1.0)"
POSITION = "gl_Position = vec4(ndc.x, ndc.y, 0.5, 1.0);"
FIRST = "    uint k = u_visible - 1u - (u_first + uint(gl_InstanceID));"
CORNERS = "    vec2 pix = r0.xy + axes * corner;"
SATURATED = "if (texelFetch(u_colour, ivec2(gl_FragCoord.xy), 0).a <= 1.0 - SL_T_STOP) discard;"
KEEP = "    alpha = alpha < SL_ALPHA_MIN ? 0.0 : alpha;"


def ten_batches(visible: int, early_termination: bool):
    """The schedule the renderer had before: doubling from 1/64 up to 1/8 of the splats."""
    out, first, size = [], 0, max(composite.MIN_BATCH, visible // 64)
    while first < visible:
        out.append((first, min(size, visible - first)))
        first += out[-1][1]
        size = min(2 * size, max(composite.MIN_BATCH, visible // 8))
    return out


# name -> (shader edits (file, old, new), early termination[, batch schedule])
ROWS = {
    "full": ((), True),
    "no raster": (((V, POSITION, f"{OUTSIDE[:-1]} + vec4(1e-9 * ndc.x));"),), True),
    "no vertex work": (((V, FIRST, f"    if (u_tile.x > -1e30) {{ {OUTSIDE}; return; }}\n{FIRST}"),), True),
    "no ET passes": (((V, FIRST, f"    if (u_tile.x > -1e30) {{ {OUTSIDE}; return; }}\n{FIRST}"),), False),
    "1 px quads": (((V, CORNERS, f"    axes = mat2(0.5);\n{CORNERS}"),), True),
    "all rejected": (((MARK, SATURATED, SATURATED.replace("<= 1.0 - SL_T_STOP", "< -1.0")),), True),
    "ET off": ((), False),
    "ten batches": ((), True, ten_batches),
}


def patched_source(edits):
    """shaders.source with the row's edits applied (each must match: the bench fails
    loudly when the shaders it instruments change)."""
    plain = shaders.source

    def source(name, *args, **kwargs):
        text = plain(name, *args, **kwargs)
        for file, old, new in edits:
            if file == name:
                if old not in text:
                    raise RuntimeError(f"colour_profile_bench: {name} no longer holds {old.strip()!r}")
                text = text.replace(old, new)
        return text
    return source


def renderer_for(edits, items, cam, **kwargs):
    """An OffscreenRenderer whose programs were built from the edited shaders."""
    from addon.gl import OffscreenRenderer

    plain = shaders.source
    shaders.source = patched_source(edits)
    try:
        r = OffscreenRenderer(depth_pass=False, **kwargs)
        r.render(items, small_camera(cam), RenderOptions())  # builds every program
    finally:
        shaders.source = plain
    return r


def timings(items, cam, runs: int) -> dict:
    renderers = {name: renderer_for(row[0], items, cam) for name, row in ROWS.items()}
    samples = {name: [] for name in ROWS}
    plain = composite.batches
    try:
        names = list(ROWS)
        for run in range(runs):
            # each run starts one row later: the first renderer of a run tends to be slower
            for name in names[run % len(names):] + names[:run % len(names)]:
                _, early, *plan = ROWS[name]
                composite.batches = plan[0] if plan else plain
                t, c = time.perf_counter(), time.process_time()
                renderers[name].render(items, cam, RenderOptions(early_termination=early))
                samples[name].append((time.perf_counter() - t, time.process_time() - c))
    finally:
        composite.batches = plain
        for r in renderers.values():
            r.close()
    return samples


COUNTERS = "layout(std430, binding = 9) buffer Counters { uint counters[]; };\n"
FETCH = "#extension GL_EXT_shader_framebuffer_fetch : require\n"


def counting_edits(fetch: bool):
    """Frag edits counting [past depth, alpha >= 1/255, of those on saturated pixels]."""
    count = ("    atomicAdd(counters[0], 1u);\n"
             "    if (alpha >= SL_ALPHA_MIN) atomicAdd(counters[1], 1u);\n"
             + ("    if (alpha >= SL_ALPHA_MIN && frag.a > 1.0 - 1.0e-4) atomicAdd(counters[2], 1u);\n"
                if fetch else ""))
    out = "layout(location = 0) out vec4 frag;"
    edits = [(F, KEEP, count + KEEP), (F, out, (out.replace(" out ", " inout ") if fetch else out) + "\n" + COUNTERS)]
    if fetch:
        edits.append((F, "#version 430\n", "#version 430\n" + FETCH))
    return edits


def counts(items, cam) -> np.ndarray:
    """One counting frame: the three fragment counts (the third -1 without fetch)."""
    import moderngl

    probe = renderer_for((), items, cam)
    fetch = "GL_EXT_shader_framebuffer_fetch" in probe._worker.call(lambda: probe._worker.ctx.extensions)
    probe.close()
    r = renderer_for(counting_edits(fetch), items, cam)
    buf = r._worker.call(lambda: r._worker.ctx.buffer(np.zeros(4, np.uint32).tobytes()))
    plain = moderngl.VertexArray.render

    def render(vao, *args, **kwargs):  # the sort reuses binding 9: bind before each draw
        if kwargs.get("instances", -1) > 1:
            buf.bind_to_storage_buffer(9)
        return plain(vao, *args, **kwargs)
    moderngl.VertexArray.render = render
    try:
        r.render(items, cam, RenderOptions())
        out = np.frombuffer(r._worker.call(buf.read), np.uint32)[:3].astype(np.int64)
    finally:
        moderngl.VertexArray.render = plain
        r._worker.call(buf.release)
        r.close()
    if not fetch:
        out[2] = -1
    return out


def saturation_timeline(items, cam, plan=None) -> list[float]:
    """Share of the frame's 4x4-pixel cells saturated (the map's level 0) when each
    marking pass runs, under the renderer's batch schedule or `plan`."""
    r = renderer_for((), items, cam)
    shares = []
    build = composite.Compositor._build_map

    def recording(self, t, w, h):
        build(self, t, w, h)
        offset, cols, rows = t["levels"][0]
        flags = np.frombuffer(t["flags"].read(size=4 * cols * rows, offset=4 * offset), np.uint32)
        shares.append(float((flags != 0).mean()))
    composite.Compositor._build_map, plain = recording, composite.batches
    composite.batches = plan or plain
    try:
        r.render(items, cam, RenderOptions())
    finally:
        composite.Compositor._build_map, composite.batches = build, plain
        r.close()
    return shares


def main(runs: int = 3):
    items, cam = scene(COUNT, *SIZE)
    samples = timings(items, cam, runs)
    full = statistics.median(s[1] for s in samples["full"])
    print(f"colour frame, {COUNT:,} splats, {SIZE[0]}x{SIZE[1]}: median of {runs} (CPU of all threads; wall)")
    for name, rows in samples.items():
        cpu, wall = statistics.median(s[1] for s in rows), statistics.median(s[0] for s in rows)
        print(f"  {name:15s} {1000 * cpu:7.0f} ms CPU ({cpu / full:4.2f} of full) {1000 * wall:7.0f} ms wall")
    for label, plan in (("", None), (" (ten batches)", ten_batches)):
        shares = saturation_timeline(items, cam, plan)
        print(f"4x4 cells saturated at each marking pass{label}: " + ", ".join(f"{x:.0%}" for x in shares))
    past, kept, late = counts(items, cam)
    pixels = SIZE[0] * SIZE[1]
    print(f"fragments past the depth test: {past / 1e6:.0f} M ({past / pixels:.0f} per pixel), "
          f"alpha >= 1/255: {kept / 1e6:.0f} M" + (f", of them on pixels already at T < 1e-4: "
                                                   f"{late / 1e6:.0f} M ({100 * late / kept:.0f}%)" if late >= 0 else ""))


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
