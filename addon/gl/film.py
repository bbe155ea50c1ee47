"""The film pass: a composited tile turned into Blender's render-result terms on the GPU
(core/scene.py Film, shaders/gl_film.frag), so the engine reads back its Combined pass
as it is, instead of converting the frame on the CPU (blender/render/film.result_rect,
the reference: about 36 ms a 1080p frame on two cores, where this pass's draw is a few).
One full-tile triangle into an RGBA32F target, read back bottom-up. The target is kept for
the next frame of that tile size: one more buffer the size of the colour target, counted in
core/budget.FRAME_COPIES."""
from __future__ import annotations

import numpy as np

from ..core.scene import Film
from . import shaders
from .uniforms import set_uniform

COLOUR_UNIT = 2  # texture unit of the tile's colour target (records use 4..6, marks 3)


class FilmPass:
    def __init__(self, ctx, records: str = "ssbo"):
        self.ctx = ctx
        self.program = ctx.program(
            vertex_shader=shaders.source("gl_fullscreen.vert", math=False, records=records),
            fragment_shader=shaders.source("gl_film.frag", records=records))
        self.vao = ctx.vertex_array(self.program, [])
        self.targets: dict = {}  # (w, h) -> (texture, framebuffer)

    def _target(self, w: int, h: int):
        if (w, h) not in self.targets:
            texture = self.ctx.texture((w, h), 4, dtype="f4")
            self.targets[(w, h)] = (texture, self.ctx.framebuffer([texture]))
        return self.targets[(w, h)]

    def run(self, colour, w: int, h: int, film: Film, background) -> np.ndarray:
        """(h, w, 4) float32, bottom-up rows: the tile's colour texture (top row first,
        premultiplied display sRGB, splats only) as Film asks, over the premultiplied
        display background first."""
        _, fbo = self._target(w, h)
        fbo.use()
        fbo.viewport = (0, 0, w, h)
        colour.use(COLOUR_UNIT)
        program = self.program
        set_uniform(program, "u_colour", COLOUR_UNIT)
        set_uniform(program, "u_background", tuple(float(v) for v in background))
        set_uniform(program, "u_over", film.under is not None)
        set_uniform(program, "u_under", tuple(float(v) for v in (film.under or (0.0, 0.0, 0.0))[:3]))
        set_uniform(program, "u_rows", h)
        self.vao.render(vertices=3)
        out = np.empty((h, w, 4), np.float32)
        fbo.read_into(out, components=4, dtype="f4")
        return out

    def release(self):
        for texture, fbo in self.targets.values():
            fbo.release()
            texture.release()
        self.vao.release()
        self.program.release()
