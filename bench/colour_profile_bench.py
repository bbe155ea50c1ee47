"""Where a final colour frame's time goes on this GL (issue 14's llvmpipe goal): the
playbot frame of final_frame_bench (500k splats, SH 2, 1920x1080, colour only) drawn by
instrumented copies of the draw shaders, each knocking out one part of the work.

    python -m bench.colour_profile_bench [runs]

Rows (median CPU of all threads and wall over the runs, frames interleaved, each run
starting at the next row):
- full: the renderer as it is.
- no raster: the vertex stage runs (records, rectangle, saturation map) but puts every
  quad outside the clip volume; what is left is upload, preprocess, sort, the
  saturation-map builds and the readback (the map stays empty: nothing is drawn).
- no vertex work: as above, but the vertex stage returns before reading anything.
- no ET passes: "no vertex work" without early termination (no map builds).
- 1 px quads: every drawn quad shrunk to about one pixel: the per-primitive cost.
- no trimming: the map culls splats whose footprint is saturated but no longer trims the
  others to their unsaturated cells.
- ET off: the full composite.
- ten batches: the batch schedule before commit 4d5c3c9, doubling from 1/64 of the splats
  to 1/8 (nine breaks where the renderer's now makes four).
Then the share of the frame's 4x4-pixel cells saturated at each break (map build), with
the renderer's batches and with ten. The instrumented copies are this bench's only: each edit
replaces one anchor string of a shader's text, and fails loudly when a shader no longer holds
it, so the bench cannot silently measure the unpatched renderer.
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

V = "gl_splat.vert"
OUTSIDE = "gl_Position = vec4(2.0, 2.0, 2.0, 1.0)"
POSITION = "gl_Position = vec4(ndc.x, ndc.y, 0.5, 1.0);"
FIRST = "    uint k = u_visible - 1u - (u_first + uint(gl_InstanceID));"
CORNERS = "    vec2 pix = r0.xy + axes * corner;"
TRIM = "const float SL_TRIM_AREA = 0.8;"


def patched_source(edits):
    """shaders.source with the edits (file, old, new) applied."""
    plain = shaders.source

    def source(name, *args, **kwargs):
        text = plain(name, *args, **kwargs)
        for file, old, new in edits:
            if file == name:
                if old not in text:
                    raise RuntimeError(f"bench shader patch: {name} no longer holds {old.strip()!r}")
                text = text.replace(old, new)
        return text
    return source


def renderer_for(edits, items, cam):
    """An OffscreenRenderer (colour only) whose programs were built from the edited shaders."""
    from addon.gl import OffscreenRenderer

    plain = shaders.source
    shaders.source = patched_source(edits)
    try:
        r = OffscreenRenderer(depth_pass=False)
        r.render(items, small_camera(cam), RenderOptions())  # builds every program
    finally:
        shaders.source = plain
    return r


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
    "no trimming": (((V, TRIM, TRIM.replace("0.8", "0.0")),), True),
    "ET off": ((), False),
    "ten batches": ((), True, ten_batches),
}


def timings(items, cam, runs: int) -> dict:
    rows = ROWS
    renderers = {name: renderer_for(row[0], items, cam) for name, row in rows.items()}
    samples = {name: [] for name in rows}
    plain = composite.batches
    try:
        names = list(rows)
        for run in range(runs):
            # each run starts one row later: the first renderer of a run tends to be slower
            for name in names[run % len(names):] + names[:run % len(names)]:
                _, early, *plan = rows[name]
                composite.batches = plan[0] if plan else plain
                t, c = time.perf_counter(), time.process_time()
                renderers[name].render(items, cam, RenderOptions(early_termination=early))
                samples[name].append((time.perf_counter() - t, time.process_time() - c))
    finally:
        composite.batches = plain
        for r in renderers.values():
            r.close()
    return samples


def saturation_timeline(items, cam, plan=None) -> list[float]:
    """Share of the frame's 4x4-pixel cells saturated (the map's level 0) at each break,
    under the renderer's batch schedule or `plan`."""
    r = renderer_for((), items, cam)
    shares = []
    build = composite.Compositor._build_map

    def recording(self, t, w, h, batch=0):
        build(self, t, w, h, batch)
        offset, words, rows = t["levels"][0]
        raw = t["flags"].read(size=4 * words * rows, offset=4 * offset)
        bits = np.unpackbits(np.frombuffer(raw, np.uint8), bitorder="little")  # little-endian words
        shares.append(float(bits.reshape(rows, 32 * words)[:, :-(-w // 4)].mean()))
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
        print(f"4x4 cells saturated at each break{label}: " + ", ".join(f"{x:.0%}" for x in shares))


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
