"""Front-to-back compositing of one tile, with early termination and the Z pass.

The splats are drawn front to back and blended "under" (dst += (1 - dst.a) * src, src
premultiplied), so the target's alpha is the accumulated alpha 1 - T, as in the
reference's loop. With options.early_termination the draw is cut into batches, and
after each one the pixels whose transmittance fell below 1e-4 are found:
- with compute shaders (GL 4.3), a saturation map (a pyramid of bitmaps over 4-pixel and
  larger cells) from which the vertex stage drops every later splat whose footprint lies
  on saturated cells only, and cuts a quad down to the box of its unsaturated cells where
  that is well smaller (gl_splat.vert); there is no depth test at all;
- on the GL 3.3 path, a full-tile pass marks those pixels in the depth buffer, and later
  fragments there fail the (early) depth test before their shader runs.
A pixel so stops at the end of the batch in which it saturated, not at the exact splat,
which moves it by at most the 1e-4 of light left behind it (and a cut-down quad's moved
corners round its interpolated offset differently: a fragment within that rounding of
the 1/255 cut may fall on the other side of it).
On the final-frame bench (llvmpipe, 1080p) depth marks on the compute path as well cost
more than their rejections saved (1.03-1.04x wall, A/B in one process, 8 frames each).

The Z pass is one more RGBA32F attachment blended the same way: its red channel sums
T_i alpha_i z_i (green and blue are masked off). Divided by the accumulated alpha it is
the alpha-weighted depth RenderOutput defines; same draws, no extra pass.

Holdout (issue 25): the surface depth map goes into a depth buffer and each quad is
drawn at its centre depth, so the early depth test drops the fragments behind a mesh;
between batches the cells a surface hides from every later splat are closed too
(gl/holdout.py says how, and what it cost). Frames without a holdout, or whose surfaces
all lie behind every splat, run the plain programs.
"""
from __future__ import annotations

import moderngl
import numpy as np

from ..core import stop
from ..core.render_constants import DEPTH_FROM_ALPHA
from . import shaders
from .holdout import depth_encoding, from_ordered_bits
from .uniforms import set_uniform

FIRST_BATCH = 1 / 16  # of the visible splats; each later batch doubles up to MAX_BATCH
MAX_BATCH = 1 / 4
MAX_BREAKS = 4  # batches - 1 at most: the last batch takes the rest (see batches)
MIN_BATCH = 4096
MARK_UNIT = 3  # texture unit of the saturation pass's colour input (records use 4..6)
SAT_LEVELS = 12  # saturation-map levels at most: cells of 4 .. 8192 pixels
B_SATURATION = 8  # storage binding of the saturation map
B_CELLS = 9  # and of its level 0 as one uint a cell, before packing
CELLS, PACK, REDUCE = 0, 1, 2  # gl_saturation_map.comp's passes
HOLDOUT_UNIT = 7  # texture unit of the tile's holdout depth map
B_MINIMA = 13  # storage binding of the batches' least centre depths (holdout)
MAX_SLOT = MAX_BREAKS + 1  # its slot of the frame's largest centre depth, after the batches'
B_CELL_MAX = 14  # storage binding of the farthest surface under each level-0 cell
MINIMA_SPAN = 64 * 64  # ranks per work group of gl_holdout_minima.comp (64 lanes x SPAN 64)
DRAW_CHUNK = 16384  # splats per draw call where the compositor flushes (software GL)
FIRST_CHUNK = 1024  # a batch's first draw there; each next one doubles up to DRAW_CHUNK


def saturation_levels(w: int, h: int) -> list[tuple[int, int, int]]:
    """(offset, words per row, rows) of each level of the tile's saturation map (level k:
    cells of 4 << k pixels, one bit each, 32 to a uint), down to the level where the tile
    is at most 2x2 cells."""
    out, offset = [], 0
    for k in range(SAT_LEVELS):
        cell = 4 << k
        cols, rows = -(-w // cell), -(-h // cell)
        words = -(-cols // 32)
        out.append((offset, words, rows))
        offset += words * rows
        if cols <= 2 and rows <= 2:
            break
    return out


def batches(visible: int, early_termination: bool) -> list[tuple[int, int]]:
    """(first, count) front-to-back batches: 1/16, 1/8, 1/4, 1/4 of the visible splats,
    then the rest. The first ones are small so that near surfaces saturate their pixels
    before the splats behind them are drawn; there are few, because every break between
    batches waits for the GL to finish, then builds the saturation map (and on GL 3.3
    draws a full-tile marking pass). On the final-frame bench (llvmpipe, 1080p, with the
    map alone), this plan took 0.97x the time of 1/16, 1/8, 1/4 and the rest in two
    A/Bs, and more breaks cost more than they saved (1/32, 1/32, 1/16, 1/8, 1/4 before
    the rest: 1.06x; seven breaks: 1.11x); in one process, 6-8 frames each (2026-11-24)."""
    if not early_termination or visible <= MIN_BATCH:
        return [(0, visible)] if visible else []
    out, first = [], 0
    size = max(MIN_BATCH, int(visible * FIRST_BATCH))
    cap = max(MIN_BATCH, int(visible * MAX_BATCH))
    while first < visible:
        count = visible - first if len(out) == MAX_BREAKS else min(size, visible - first)
        out.append((first, count))
        first += count
        size = min(2 * size, cap)
    return out


class Compositor:
    def __init__(self, ctx, records: str = "ssbo", flush=None):
        """flush: a glFlush to call between a batch's draws on a software GL (see _draw),
        or None to draw each batch in one call."""
        self.ctx = ctx
        self.flush = flush
        # the saturation map needs compute shaders and storage buffers (GL 4.3); without
        # it, early termination marks the depth buffer instead
        self.sat_map = [ctx.compute_shader(shaders.source("gl_saturation_map.comp", math=False,
                                                          defines={"SL_PASS": kind}))
                        for kind in (CELLS, PACK, REDUCE)] if records == "ssbo" else None
        defines = {"SL_SATURATION_MAP": SAT_LEVELS} if self.sat_map else {}
        self.draw = ctx.program(
            vertex_shader=shaders.source("gl_splat.vert", records=records, defines=defines),
            fragment_shader=shaders.source("gl_splat.frag", records=records))
        self.mark = None if self.sat_map else ctx.program(
            vertex_shader=shaders.source("gl_fullscreen.vert", math=False, records=records),
            fragment_shader=shaders.source("gl_saturate.frag", math=False, records=records))
        self.vaos = {p: ctx.vertex_array(p, []) for p in (self.draw, self.mark) if p}
        self.records = records
        self.variants = {False: (self.draw, self.mark)}  # holdout variant compiled on first use
        self.sat_cells = {False: self.sat_map[CELLS]} if self.sat_map else {}
        self.minima = None  # (program, buffer) on the compute path, once a holdout comes
        self.resolve = None  # the surface map -> depth buffer program, once a holdout comes
        self.cell_max = None  # the farthest surface per cell (compute path), likewise
        self.held = None  # this tile's holdout: texture, batches, saturate; or None
        self.targets: dict = {}
        self.splat_draws = 0  # batches of splats drawn in the last tile (stats and tests)
        self.breaks = 0  # early-termination passes between them (map or marks)
        self.flushes = 0

    def _targets(self, w: int, h: int) -> dict:
        if (w, h) not in self.targets:
            ctx = self.ctx
            colour = ctx.texture((w, h), 4, dtype="f4")
            z = ctx.texture((w, h), 4, dtype="f4")
            colour.filter = moderngl.NEAREST, moderngl.NEAREST
            t = {"colour": colour, "z": z}
            if self.sat_map is not None:
                levels = saturation_levels(w, h)
                t["levels"] = levels
                t["flags"] = ctx.buffer(reserve=4 * (levels[-1][0] + levels[-1][1] * levels[-1][2]))
                t["cells"] = ctx.buffer(reserve=4 * -(-w // 4) * levels[0][2])
                t["plain"] = ctx.framebuffer([colour])
                t["with_z"] = ctx.framebuffer([colour, z])
            else:
                t["depth"] = depth = ctx.depth_renderbuffer((w, h))
                t["plain"] = ctx.framebuffer([colour], depth)
                t["with_z"] = ctx.framebuffer([colour, z], depth)
                t["mark"] = ctx.framebuffer([], depth)
                t["plain"].depth_mask = t["with_z"].depth_mask = False
            # the Z target uses red (T alpha z) and alpha (T alpha) only: masking green and
            # blue spares their blending: 0.84-0.95x the time of a Z frame on llvmpipe (three
            # A/Bs at 1080p), the same pixels and depths bit for bit
            t["with_z"].color_mask = ((True, True, True, True), (True, False, False, True))
            self.targets[(w, h)] = t
        return self.targets[(w, h)]

    def colour(self, w: int, h: int):
        """The colour target of the last tile of this size drawn (premultiplied, top row first)."""
        return self.targets[(w, h)]["colour"]

    def programs_for(self, holdout: bool):
        """(draw, mark) programs with or without the holdout test (compiled once)."""
        if holdout not in self.variants:
            ctx, records = self.ctx, self.records
            defines = {"SL_HOLDOUT": 1}
            if self.sat_map:
                defines["SL_SATURATION_MAP"] = SAT_LEVELS
                self.sat_cells[True] = ctx.compute_shader(shaders.source(
                    "gl_saturation_map.comp", math=False, defines={"SL_PASS": CELLS, "SL_HOLDOUT": 1}))
                self.minima = (ctx.compute_shader(shaders.source("gl_holdout_minima.comp", math=False)),
                               ctx.buffer(reserve=4 * (MAX_SLOT + 1)))
                self.cell_max = ctx.compute_shader(shaders.source("gl_holdout_cells.comp", math=False))
            draw = ctx.program(
                vertex_shader=shaders.source("gl_splat.vert", records=records, defines=defines),
                fragment_shader=shaders.source("gl_splat.frag", records=records, defines=defines))
            mark = None if self.sat_map else ctx.program(
                vertex_shader=shaders.source("gl_fullscreen.vert", math=False, records=records),
                fragment_shader=shaders.source("gl_saturate.frag", math=False, records=records,
                                               defines={"SL_HOLDOUT": 1}))
            self.resolve = ctx.program(
                vertex_shader=shaders.source("gl_fullscreen.vert", math=False, records=records),
                fragment_shader=shaders.source("gl_holdout_resolve.frag", math=False, records=records))
            for p in (draw, mark, self.resolve):
                if p is not None:
                    self.vaos[p] = ctx.vertex_array(p, [])
            self.variants[holdout] = (draw, mark)
        return self.variants[holdout]

    def run(self, tile, visible: int, early_termination: bool, want_z: bool, capped: bool = False,
            surface=None, front_depths=None):
        """Composite one tile (the order and records are bound). Returns (rgba, depth):
        (h, w, 4) premultiplied splats only (no background) and (h, w) alpha-weighted
        depth (inf below alpha 0.5, or everywhere without want_z), both top-down.
        surface: the frame's holdout (gl/holdout.Surface: its depth bounds, and its map of
        this tile drawn on demand), or None; front_depths: on the GL 3.3 path, the records'
        centre depths back to front."""
        x0, y0, w, h = tile
        compute = self.sat_map is not None
        plan = batches(visible, early_termination or (surface is not None and compute))
        if surface is not None:
            self.programs_for(True)  # compiles the holdout programs on first use
        enc = self._encoding(surface, plan, visible, front_depths) if surface is not None and visible else None
        if enc is None:
            plan = batches(visible, early_termination)
        self.draw, self.mark = self.programs_for(enc is not None)
        t = self._targets(w, h)
        if "mark" in t:
            t["mark"].clear(depth=1.0)  # the splat framebuffers don't write depth, not even clears
        self.held = None
        if enc is not None:
            texture = surface.draw(tile)
            self.held = {"batches": len(plan), "saturate": bool(early_termination)}
            self._resolve(t, w, h, texture, enc)
            set_uniform(self.draw, "u_holdout_enc", enc)
        suffix = "_held" if self.held is not None and compute else ""
        fbo = t[("with_z" if want_z else "plain") + suffix]
        fbo.use()
        fbo.viewport = (0, 0, w, h)
        fbo.clear(0.0, 0.0, 0.0, 0.0)
        self.splat_draws = self.breaks = self.flushes = 0
        draw, ctx = self.draw, self.ctx
        draw["u_tile"].value = (float(x0), float(y0), float(w), float(h))
        draw["u_capped_extent"].value = bool(capped)
        if "u_visible" in draw:
            draw["u_visible"].value = visible
        self._use_map(t, 0)
        tests = moderngl.BLEND | (moderngl.DEPTH_TEST if "mark" in t or self.held is not None else 0)
        ctx.enable(tests)
        ctx.depth_func = "<"
        ctx.blend_func = moderngl.ONE_MINUS_DST_ALPHA, moderngl.ONE
        for number, (first, count) in enumerate(plan):
            if number:
                stop.check()  # between batches: a requested stop need not wait for the tile
                self._break(t, w, h, number)
                fbo.use()
            self._draw(first, count)
        ctx.disable(tests)
        return self._read(fbo, w, h, want_z)

    def _encoding(self, surface, plan, visible: int, front_depths):
        """(lo, scale) of the depth encoding enc(z) = ENC_BASE + (z - lo) scale, over the
        depths where the splats' centres and the surface's possible hits overlap; None
        where every surface lies behind every splat (nothing to hold out: the plain
        programs run). On the compute path this gathers each batch's least centre depth
        into the minima buffer (the cells pass closes by them) and reads back the range."""
        if self.sat_map is None:
            front = np.asarray(front_depths, np.float32)[:visible]
            near, far = float(front.min()), float(front.max())
        else:
            cs, buf = self.minima
            init = np.full(MAX_SLOT + 1, 0xFFFFFFFF, np.uint32)
            init[MAX_SLOT] = 0
            buf.write(init.tobytes())
            buf.bind_to_storage_buffer(B_MINIMA)
            cs["u_visible"].value = visible
            cs["u_max_slot"].value = MAX_SLOT
            for slot, (first, count) in enumerate(plan):
                cs["u_first"].value = first
                cs["u_count"].value = count
                cs["u_slot"].value = slot
                cs.run(-(-count // MINIMA_SPAN))
            self.ctx.memory_barrier()
            got = from_ordered_bits(np.frombuffer(buf.read(), np.uint32))
            near, far = float(got[:len(plan)].min()), float(got[MAX_SLOT])
        return depth_encoding(near, far, *surface.bounds)

    def _resolve(self, t: dict, w: int, h: int, texture, enc):
        """The surface map into the tile's depth buffer, encoded (gl_holdout_resolve.frag)."""
        if "depth" not in t:  # compute path: a depth buffer only for holdout frames
            ctx = self.ctx
            t["depth"] = depth = ctx.depth_renderbuffer((w, h))
            t["plain_held"] = ctx.framebuffer([t["colour"]], depth)
            t["with_z_held"] = ctx.framebuffer([t["colour"], t["z"]], depth)
            t["resolve"] = ctx.framebuffer([], depth)
            t["plain_held"].depth_mask = t["with_z_held"].depth_mask = False
            t["with_z_held"].color_mask = ((True, True, True, True), (True, False, False, True))
        fbo = t["resolve"] if "resolve" in t else t["mark"]
        fbo.use()
        fbo.viewport = (0, 0, w, h)
        ctx = self.ctx
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = "1"  # always
        texture.use(HOLDOUT_UNIT)
        set_uniform(self.resolve, "u_holdout", HOLDOUT_UNIT)
        set_uniform(self.resolve, "u_holdout_enc", enc)
        self.vaos[self.resolve].render(moderngl.TRIANGLES, vertices=3)
        ctx.disable(moderngl.DEPTH_TEST)
        if self.sat_map is not None:  # the farthest surface per cell, for the cells pass
            cols, rows = -(-w // 4), t["levels"][0][2]
            if "cell_max" not in t:
                t["cell_max"] = ctx.buffer(reserve=4 * cols * rows)
            t["cell_max"].bind_to_storage_buffer(B_CELL_MAX)
            cs = self.cell_max
            set_uniform(cs, "u_holdout", HOLDOUT_UNIT)
            set_uniform(cs, "u_size", (cols, rows))
            set_uniform(cs, "u_tile_size", (w, h))
            cs.run((cols + 7) // 8, (rows + 7) // 8)
            ctx.memory_barrier()

    def _break(self, t: dict, w: int, h: int, batch: int = 0):
        """Before batch `batch` (> 0): find the pixels closed so far (saturated, or with a
        holdout on the compute path, hidden from every splat to come) for the next
        batches' culling."""
        if self.sat_map is not None:
            self._build_map(t, w, h, batch)
        else:
            self._mark(t, w, h, batch)
        self.breaks += 1

    def _draw(self, first: int, count: int):
        """Front-to-back ranks first .. first + count - 1. Where flushing (software GL),
        in draws of FIRST_CHUNK splats doubling up to DRAW_CHUNK, with a glFlush after
        each: llvmpipe bins a draw's triangles on the GL thread, and its raster threads
        start on them only once they are flushed, so a batch drawn whole leaves them idle
        while it is binned; in chunks they rasterise one while the next is binned, and a
        small first chunk sets them to work soon after each break, when they are idle.
        Final-frame bench colour frame at 1080p: DRAW_CHUNK chunks took 0.92x and 0.96x
        the wall time of whole batches in two A/Bs of 10 frames each (0.96x and 0.99x the
        CPU); the ramp from FIRST_CHUNK 0.97-1.00x the wall time of DRAW_CHUNK chunks
        throughout (three A/Bs, 8-12 frames). The same pixels bit for bit, as the order is
        unchanged."""
        draw = self.draw
        flushing = self.flush is not None and "u_first" in draw
        end, step = first + count, (min(FIRST_CHUNK, DRAW_CHUNK) if flushing else count)
        start = first
        while start < end:
            n = min(step, end - start)
            if "u_first" in draw:
                draw["u_first"].value = start
            self.vaos[draw].render(moderngl.TRIANGLE_STRIP, vertices=4, instances=n)
            if flushing:
                self.flush()
                self.flushes += 1
            start += n
            step = min(2 * step, DRAW_CHUNK) if flushing else step
        self.splat_draws += 1

    @staticmethod
    def _read(fbo, w: int, h: int, want_z: bool):
        """The tile's colour and, with want_z, the weighted depth sum divided by alpha.
        The draw stage puts the top row first, so the targets' rows read straight into
        the arrays (on llvmpipe a 1080p read_into takes ~3 ms; read, flip and copy ~20)."""
        rgba = np.empty((h, w, 4), np.float32)
        fbo.read_into(rgba, components=4, dtype="f4")
        if not want_z:
            return rgba, np.full((h, w), np.inf, np.float32)
        weighted = np.empty((h, w), np.float32)
        fbo.read_into(weighted, components=1, attachment=1, dtype="f4")
        alpha = rgba[..., 3]
        with np.errstate(divide="ignore", invalid="ignore"):
            depth = np.where(alpha >= DEPTH_FROM_ALPHA, weighted / alpha, np.inf)
        return rgba, depth.astype(np.float32)

    def _mark(self, t: dict, w: int, h: int, batch: int = 0):
        """Depth-mark the saturated pixels (T < 1e-4) of the tile so far (with a holdout
        at depth 0: the splats' depths are encoded; gl_saturate.frag)."""
        mark = t["mark"]
        mark.use()
        mark.viewport = (0, 0, w, h)
        ctx = self.ctx
        ctx.disable(moderngl.BLEND)
        t["colour"].use(MARK_UNIT)
        self.mark["u_colour"].value = MARK_UNIT
        self.vaos[self.mark].render(moderngl.TRIANGLES, vertices=3)
        ctx.enable(moderngl.BLEND)

    def _build_map(self, t: dict, w: int, h: int, batch: int = 0):
        """The saturation map of the tile so far, for the draw stage's culling (with a
        holdout, closing too the cells whose surface hides every splat from `batch` on)."""
        t["colour"].use(MARK_UNIT)
        t["flags"].bind_to_storage_buffer(B_SATURATION)
        t["cells"].bind_to_storage_buffer(B_CELLS)
        cols, rows = -(-w // 4), t["levels"][0][2]
        held = {}
        if self.held is not None:
            self.minima[1].bind_to_storage_buffer(B_MINIMA)
            t["cell_max"].bind_to_storage_buffer(B_CELL_MAX)
            held = {"u_batch": batch, "u_batches": self.held["batches"], "u_saturate": self.held["saturate"]}
        self._map_pass(CELLS, (cols, rows), u_colour=MARK_UNIT, u_tile_size=(w, h), **held)
        below = (0, 1, 1)
        for k, (offset, words, rows) in enumerate(t["levels"]):
            self._map_pass(REDUCE if k else PACK, (words, rows), u_offset=offset, u_cells=cols,
                           u_below=below[0], u_below_size=below[1:])
            below = (offset, words, rows)
        self._use_map(t, len(t["levels"]))

    def _map_pass(self, kind: int, size: tuple[int, int], **uniforms):
        cs = self.sat_cells[self.held is not None] if kind == CELLS else self.sat_map[kind]
        cs["u_size"].value = size
        for name, value in uniforms.items():
            set_uniform(cs, name, value)  # each pass keeps only the uniforms it reads
        cs.run((size[0] + 7) // 8, (size[1] + 7) // 8)
        self.ctx.memory_barrier()

    def _use_map(self, t: dict, levels: int):
        """Let the draw stage read the map's first `levels` levels (0: cull nothing)."""
        if self.sat_map is None:
            return
        draw = self.draw
        draw["u_sat_levels"].value = levels
        if levels:
            t["flags"].bind_to_storage_buffer(B_SATURATION)
            pad = [(0, 1, 1)] * (SAT_LEVELS - len(t["levels"]))
            draw["u_sat_offset"].value = [lv[0] for lv in t["levels"] + pad]
            draw["u_sat_size"].value = [lv[1:] for lv in t["levels"] + pad]

    def release(self):
        for t in self.targets.values():
            for name, obj in t.items():
                if name != "levels":
                    obj.release()
        programs = [p for pair in self.variants.values() for p in pair]
        extra = list(self.sat_cells.values())[1:] + list(self.minima or []) + [self.resolve, self.cell_max]
        for obj in list(self.vaos.values()) + programs + (self.sat_map or []) + extra:
            if obj is not None:
                obj.release()

