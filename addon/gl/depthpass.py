"""Depth pass: per pixel, the view depth of the splat at which the front-to-back
accumulated alpha first reaches 0.5 (inf where it never does), as RenderOutput defines.

Blending cannot test the accumulated alpha before it draws, so this bisects: each pixel
keeps a rank interval [lo, hi] over the front-to-back order, and each step draws every
splat with rank <= mid into a transmittance target (multiplicative blending), then
narrows the interval from T(mid) <= 0.5. ceil(log2(visible + 1)) steps find the exact
first rank; a last pass turns the rank into that splat's depth. The splats are drawn
with the same alpha as the colour pass, so the answer matches the colour it sits in.
Cost: about log2(visible) extra draws without colour, per frame.
"""
from __future__ import annotations

import moderngl
import numpy as np

from . import shaders


class DepthPass:
    def __init__(self, ctx):
        self.ctx = ctx
        self.splat = ctx.program(vertex_shader=shaders.source("gl_splat.vert"),
                                 fragment_shader=shaders.source("gl_depth_splat.frag"))
        full = shaders.source("gl_fullscreen.vert", math=False)
        self.update = ctx.program(vertex_shader=full,
                                  fragment_shader=shaders.source("gl_depth_update.frag", math=False))
        self.resolve = ctx.program(vertex_shader=full,
                                   fragment_shader=shaders.source("gl_depth_resolve.frag", math=False))
        self.vaos = {p: ctx.vertex_array(p, []) for p in (self.splat, self.update, self.resolve)}
        self.targets: dict = {}
        self.steps = 0  # bisection steps of the last frame (for stats and tests)

    def _targets(self, w: int, h: int) -> dict:
        if (w, h) not in self.targets:
            tex = {
                "a": self.ctx.texture((w, h), 2, dtype="f4"),
                "b": self.ctx.texture((w, h), 2, dtype="f4"),
                "t": self.ctx.texture((w, h), 1, dtype="f4"),
                "d": self.ctx.texture((w, h), 1, dtype="f4"),
            }
            for t in tex.values():
                t.filter = moderngl.NEAREST, moderngl.NEAREST
            fbos = {k: self.ctx.framebuffer(color_attachments=[t]) for k, t in tex.items()}
            self.targets[(w, h)] = (tex, fbos)
        return self.targets[(w, h)]

    def run(self, tile, visible: int) -> np.ndarray:
        """(h, w) float32 top-down depth of one tile; the order and records are bound."""
        x0, y0, w, h = tile
        if visible == 0:
            return np.full((h, w), np.inf, np.float32)
        tex, fbos = self._targets(w, h)
        fbos["a"].use()
        fbos["a"].viewport = (0, 0, w, h)
        fbos["a"].clear(0.0, float(visible), 0.0, 0.0)
        self.splat["u_tile"].value = (float(x0), float(y0), float(w), float(h))
        self.splat["u_visible"].value = visible
        src, dst = "a", "b"
        self.steps = int(visible).bit_length()
        for _ in range(self.steps):
            self._transmittance(tex[src], fbos["t"], visible, w, h)
            self._narrow(tex[src], tex["t"], fbos[dst], w, h)
            src, dst = dst, src
        fbos["d"].use()
        fbos["d"].viewport = (0, 0, w, h)
        tex[src].use(0)
        self.resolve["u_bounds"].value = 0
        self.resolve["u_visible"].value = visible
        self.vaos[self.resolve].render(moderngl.TRIANGLES, vertices=3)
        data = np.frombuffer(fbos["d"].read(components=1, dtype="f4"), np.float32)
        return data.reshape(h, w)[::-1].copy()

    def _transmittance(self, bounds, fbo, visible: int, w: int, h: int):
        fbo.use()
        fbo.viewport = (0, 0, w, h)
        fbo.clear(1.0, 1.0, 1.0, 1.0)
        bounds.use(0)
        self.splat["u_bounds"].value = 0
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.ZERO, moderngl.ONE_MINUS_SRC_ALPHA
        self.vaos[self.splat].render(moderngl.TRIANGLE_STRIP, vertices=4, instances=visible)
        self.ctx.disable(moderngl.BLEND)

    def _narrow(self, bounds, trans, fbo, w: int, h: int):
        fbo.use()
        fbo.viewport = (0, 0, w, h)
        bounds.use(0)
        trans.use(1)
        self.update["u_bounds"].value = 0
        self.update["u_trans"].value = 1
        self.vaos[self.update].render(moderngl.TRIANGLES, vertices=3)

    def release(self):
        for tex, fbos in self.targets.values():
            for obj in list(fbos.values()) + list(tex.values()):
                obj.release()
        for obj in list(self.vaos.values()) + [self.splat, self.update, self.resolve]:
            obj.release()
