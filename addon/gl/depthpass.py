"""Depth pass: per pixel, the view depth of the splat at which the front-to-back
accumulated alpha first reaches 0.5 (inf where it never does), as RenderOutput defines.

Blending cannot test the accumulated alpha before it draws, so this searches: each pixel
keeps an interval [lo, hi] of front-to-back ranks holding the answer (hi = visible count
means "never"). A step draws every splat once into two RGBA32F targets, giving the
transmittance T(m_j) at 8 probe ranks m_j that split the interval in 9 (each channel
keeps only ranks <= its probe: blend ZERO, ONE_MINUS_SRC_COLOR), then narrows the interval
(T(m_j) <= 0.5: the answer is <= m_j). About log9(visible) + 1 steps find the exact first
rank; a last pass turns it into that splat's depth. The splats are drawn with the same
alpha as the colour pass, so the depth matches the colour it sits in.
"""
from __future__ import annotations

import moderngl
import numpy as np

from . import shaders

PROBES = 8
COMMON = ("gl_depth_common.glsl",)


def search_steps(visible: int) -> int:
    """Steps until every interval of length `visible` shrinks to one rank."""
    steps, length = 0, int(visible)
    while length > 0:
        cuts = [length * j // (PROBES + 1) for j in range(1, PROBES + 1)]
        pieces = [cuts[0]] + [b - a - 1 for a, b in zip(cuts, cuts[1:])] + [length - cuts[-1] - 1]
        length = max(pieces)
        steps += 1
    return steps


class DepthPass:
    def __init__(self, ctx, records: str = "ssbo"):
        self.ctx = ctx
        self.splat = ctx.program(
            vertex_shader=shaders.source("gl_splat.vert", records=records),
            fragment_shader=shaders.source("gl_depth_splat.frag", includes=COMMON, records=records))
        full = shaders.source("gl_fullscreen.vert", math=False, records=records)
        self.update = ctx.program(
            vertex_shader=full, fragment_shader=shaders.source(
                "gl_depth_update.frag", math=False, includes=COMMON, records=records))
        self.resolve = ctx.program(
            vertex_shader=full,
            fragment_shader=shaders.source("gl_depth_resolve.frag", math=False, records=records))
        self.init = ctx.program(
            vertex_shader=full,
            fragment_shader=shaders.source("gl_depth_init.frag", math=False, records=records))
        self.vaos = {p: ctx.vertex_array(p, []) for p in (self.splat, self.update, self.resolve, self.init)}
        self.targets: dict = {}
        self.steps = 0  # search steps of the last frame (for stats and tests)

    def _targets(self, w: int, h: int):
        if (w, h) not in self.targets:
            tex = {"a": self.ctx.texture((w, h), 2, dtype="f4"),
                   "b": self.ctx.texture((w, h), 2, dtype="f4"),
                   "t0": self.ctx.texture((w, h), 4, dtype="f4"),
                   "t1": self.ctx.texture((w, h), 4, dtype="f4"),
                   "d": self.ctx.texture((w, h), 1, dtype="f4")}
            for t in tex.values():
                t.filter = moderngl.NEAREST, moderngl.NEAREST
            fbos = {k: self.ctx.framebuffer(color_attachments=[tex[k]]) for k in ("a", "b", "d")}
            fbos["t"] = self.ctx.framebuffer(color_attachments=[tex["t0"], tex["t1"]])
            self.targets[(w, h)] = (tex, fbos)
        return self.targets[(w, h)]

    def run(self, tile, visible: int, colour=None, background_alpha: float = 0.0) -> np.ndarray:
        """(h, w) float32 top-down depth of one tile; the order and records are bound.
        colour: the tile's colour-pass texture; pixels it shows below alpha 0.5 skip the search."""
        x0, y0, w, h = tile
        if visible == 0:
            self.steps = 0
            return np.full((h, w), np.inf, np.float32)
        tex, fbos = self._targets(w, h)
        self._use(fbos["a"], w, h)
        if colour is None or background_alpha > 0.9:  # nearly opaque film: alpha tells nothing
            fbos["a"].clear(0.0, float(visible), 0.0, 0.0)
        else:
            colour.use(0)
            self.init["u_colour"].value = 0
            self.init["u_visible_f"].value = float(visible)
            self.init["u_alpha_floor"].value = float(background_alpha)
            self.vaos[self.init].render(moderngl.TRIANGLES, vertices=3)
        self.splat["u_tile"].value = (float(x0), float(y0), float(w), float(h))
        self.splat["u_visible"].value = visible
        src, dst = "a", "b"
        self.steps = search_steps(visible)
        for _ in range(self.steps):
            self._probe(tex[src], fbos["t"], visible, w, h)
            self._narrow(tex[src], tex, fbos[dst], w, h)
            src, dst = dst, src
        self._use(fbos["d"], w, h)
        tex[src].use(0)
        self.resolve["u_bounds"].value = 0
        self.resolve["u_visible"].value = visible
        self.vaos[self.resolve].render(moderngl.TRIANGLES, vertices=3)
        data = np.frombuffer(fbos["d"].read(components=1, dtype="f4"), np.float32)
        return data.reshape(h, w)[::-1].copy()

    @staticmethod
    def _use(fbo, w: int, h: int):
        fbo.use()
        fbo.viewport = (0, 0, w, h)

    def _probe(self, bounds, fbo, visible: int, w: int, h: int):
        self._use(fbo, w, h)
        fbo.clear(1.0, 1.0, 1.0, 1.0)
        bounds.use(0)
        self.splat["u_bounds"].value = 0
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.ZERO, moderngl.ONE_MINUS_SRC_COLOR
        self.vaos[self.splat].render(moderngl.TRIANGLE_STRIP, vertices=4, instances=visible)
        self.ctx.disable(moderngl.BLEND)

    def _narrow(self, bounds, tex, fbo, w: int, h: int):
        self._use(fbo, w, h)
        bounds.use(0)
        tex["t0"].use(1)
        tex["t1"].use(2)
        self.update["u_bounds"].value = 0
        self.update["u_trans_lo"].value = 1
        self.update["u_trans_hi"].value = 2
        self.vaos[self.update].render(moderngl.TRIANGLES, vertices=3)

    def release(self):
        for tex, fbos in self.targets.values():
            for obj in list(fbos.values()) + list(tex.values()):
                obj.release()
        for obj in list(self.vaos.values()) + [self.splat, self.update, self.resolve, self.init]:
            obj.release()
