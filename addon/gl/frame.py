"""The GL-thread side of the offscreen renderer: one frame = upload, preprocess, sort,
draw, readback (each a small method). Runs only on the renderer's GL thread."""
from __future__ import annotations

import math

import numpy as np

from ..core import stop
from ..core.camera import Camera
from ..core.scene import RenderItem, RenderOptions, RenderOutput
from . import shaders
from .composite import Compositor
from .fallback import RecordTextures, cpu_records
from .film import FilmPass
from .holdout import HoldoutPass, Surface, active
from .software import gl_flush, is_software
from .sort import RadixSorter, cpu_order, sorts_on_gpu
from .uniforms import camera_uniforms, depth_origin, item_uniforms, set_uniform, slots_per_splat
from .upload import UploadCache

MAX_TILE = 4096  # larger frames are drawn tile by tile (bounded GPU memory)
B_ORDER, B_REC0, B_REC1, B_REC2, B_DEPTH, B_RANGE = 0, 3, 4, 5, 6, 7
FRAME_ARRAYS = {"rec0": 16, "rec1": 16, "rec2": 16, "depth": 4,
                "keys": 4, "vals": 4, "keys2": 4, "vals2": 4, "order": 4}


class FrameState:
    def __init__(self, ctx, stats: dict, compute: bool | None = None):
        """compute: None = compute shaders where GL >= 4.3; False = the GL 3.3 fallback."""
        if ctx.version_code < 330:
            raise RuntimeError(f"the offscreen renderer needs OpenGL 3.3; this context is "
                               f"{ctx.version_code}")
        self.compute = ctx.version_code >= 430 and compute is not False
        records = "ssbo" if self.compute else "texture"
        self.ctx = ctx
        self.stats = stats
        self.cache = UploadCache(ctx, stats)
        self.sorter = RadixSorter(ctx) if self.compute else None
        self.gl_renderer = ctx.info.get("GL_RENDERER", "")
        self.record_textures = None if self.compute else RecordTextures(ctx)
        self.compositor = Compositor(ctx, records, gl_flush(ctx) if is_software(self.gl_renderer) else None)
        self.holdout = HoldoutPass(ctx, stats, 430 if self.compute else 330)
        self.preprocess = {}  # compute programs by preprocess_defines
        self.film_pass = None  # made on the first frame that asks for a film
        self.range = ctx.buffer(reserve=12) if self.compute else None
        self.dummy = ctx.buffer(reserve=16) if self.compute else None
        self.capacity = 0
        self.arrays: dict = {}
        self.last = (None, 0, 0)
        self.want_depth = True

    @property
    def record_limit(self) -> int:
        """Most splats one frame can hold on the compute path: one vec4 record per splat
        in one storage block (GL_MAX_SHADER_STORAGE_BLOCK_SIZE; ~8.4M at 128 MiB)."""
        return self.cache.max_block // 16

    # -- frame-wide arrays -------------------------------------------------------------
    def _ensure(self, n: int):
        if n <= self.capacity:
            return
        cap = max(1024, 1 << math.ceil(math.log2(n)))
        limit = self.record_limit
        if n > limit:  # OffscreenRenderer sends such frames to the GL 3.3 path instead
            raise RuntimeError(f"{n:,} splats in one frame exceed this GL's storage blocks "
                               f"({limit:,})")
        cap = min(cap, limit)
        for buf in self.arrays.values():
            buf.release()
        self.arrays = {k: self.ctx.buffer(reserve=size * cap) for k, size in FRAME_ARRAYS.items()}
        self.capacity = cap

    # -- stages ------------------------------------------------------------------------
    def _preprocess(self, items, objects, camera, options, track_range: bool) -> int | None:
        """Project every splat into the frame arrays. track_range: also gather the depth
        range and visible count the GPU sort needs (atomics in every invocation: on
        llvmpipe about a sixth of the stage, so not where the CPU sorts); returns the
        visible count, or None without track_range."""
        self.range.write(np.array([0xFFFFFFFF, 0, 0], np.uint32).tobytes())
        a = self.arrays
        for binding, name in ((B_REC0, "rec0"), (B_REC1, "rec1"), (B_REC2, "rec2"), (B_DEPTH, "depth")):
            a[name].bind_to_storage_buffer(binding)
        self.range.bind_to_storage_buffer(B_RANGE)
        cs = self._preprocess_program(camera)
        for name, value in camera_uniforms(camera).items():
            set_uniform(cs, name, value)
        set_uniform(cs, "u_antialiased", bool(options.antialiased))
        set_uniform(cs, "u_capped_extent", bool(options.capped_extent))
        set_uniform(cs, "u_track_range", bool(track_range))
        copies = slots_per_splat(camera) > 1
        set_uniform(cs, "u_copy_stride", sum(obj.count for obj in objects) if copies else 0)
        base = 0
        anchor = depth_origin(items[0], camera) if items else 0.0
        for item, obj in zip(items, objects):
            for name, value in item_uniforms(item, camera, anchor).items():
                set_uniform(cs, name, value)
            set_uniform(cs, "u_rest_count", obj.rest_coeffs)
            for part in obj.parts:
                part.geom.bind_to_storage_buffer(0)
                (part.rest or self.dummy).bind_to_storage_buffer(2)
                set_uniform(cs, "u_count", part.count)
                set_uniform(cs, "u_base", base + part.start)
                cs.run((part.count + 255) // 256)
            base += obj.count
        self.ctx.memory_barrier()
        return int(np.frombuffer(self.range.read(), np.uint32)[2]) if track_range else None

    def _preprocess_program(self, camera: Camera):
        key = preprocess_defines(camera)
        if key not in self.preprocess:
            self.preprocess[key] = self.ctx.compute_shader(
                shaders.source("gl_preprocess.comp", defines=dict(key)))
        return self.preprocess[key]

    def _sort_gpu(self, n: int, options: RenderOptions):
        """Leaves the back-to-front order of the visible splats in a buffer; returns it."""
        a = self.arrays
        self.sorter.make_keys(n, options.key_bits, a["depth"], self.range, a["keys"], a["vals"])
        self.sorter.sort(n, options.key_bits, a["keys"], a["vals"], a["keys2"], a["vals2"])
        self.stats["gpu_sorts"] += 1
        return a["vals"]

    def _sort_cpu(self, n: int, options: RenderOptions):
        """The same order from the depths read back (numpy); returns (buffer, visible)."""
        a = self.arrays
        depth = np.frombuffer(a["depth"].read(size=4 * n), np.float32)
        order = cpu_order(depth, options.key_bits)
        if len(order):
            a["order"].write(order.tobytes())
        self.stats["cpu_sorts"] += 1
        return a["order"], len(order)

    def _project(self, items, camera, options, track_range: bool = False):
        """Upload (cached) and preprocess: returns (record slots, visible count or None)."""
        self.cache.begin_frame()
        objects = [self.cache.get(item) for item in items]
        n = sum(obj.count for obj in objects) * slots_per_splat(camera)
        self._ensure(max(n, 1))
        if not n:
            return 0, 0
        return n, self._preprocess(items, objects, camera, options, track_range)

    def _gpu_prepare(self, items, camera, options):
        """Upload, preprocess and sort with compute shaders; bind the frame's records."""
        gpu_sort = sorts_on_gpu(options.gpu_sort, self.gl_renderer)
        n, visible = self._project(items, camera, options, track_range=gpu_sort)
        self.cache.retain({item.key for item in items if item.key is not None})
        a = self.arrays
        if not n:
            order = a["order"]
        elif gpu_sort:
            order = self._sort_gpu(n, options) if visible else a["order"]
        else:
            order, visible = self._sort_cpu(n, options)
        for binding, buf in ((B_ORDER, order), (B_REC0, a["rec0"]), (B_REC1, a["rec1"]), (B_REC2, a["rec2"])):
            buf.bind_to_storage_buffer(binding)
        return order, visible, n

    # -- one frame ---------------------------------------------------------------------
    def render(self, items: list[RenderItem], camera: Camera, options: RenderOptions) -> RenderOutput:
        if options.key_bits not in (16, 32):
            raise ValueError(f"key bits must be 16 or 32, not {options.key_bits}")
        holdout = active(options)
        surface = Surface(self.holdout, holdout, camera) if holdout is not None else None
        front_depths = None
        if self.compute:
            order, visible, n = self._gpu_prepare(items, camera, options)
        else:
            records, visible = cpu_records(items, camera, options)
            stop.check()  # a stop requested (Ctrl+C, SIGTERM) ends the frame between stages
            self.record_textures.upload(records, self.stats)
            for program in {self.compositor.programs_for(False)[0],
                            self.compositor.programs_for(surface is not None)[0]}:
                self.record_textures.bind(program)
            self.stats["cpu_sorts"] += 1
            order, n = None, sum(item.splats.count for item in items)
            front_depths = records[1, :, 2]  # back to front: the draw stage's centre depths
        rgba, depth, combined = self._composite(camera, visible, options, surface, front_depths)
        behind(rgba, options.background)
        self.stats["frames"] += 1
        self.stats["resident_objects"] = self.cache.resident
        self.last = (order, visible, n)
        return RenderOutput(rgba, depth, combined)

    def _composite(self, camera: Camera, visible: int, options: RenderOptions, surface=None,
                   front_depths=None):
        """The frame's (rgba, depth, film), tile by tile; a frame of one tile is its
        arrays. combined: the flat Combined pass where options.film asks for it, else None.
        surface: the frame's holdout (gl/holdout.Surface), or None."""
        frame_tiles = list(tiles(camera.width, camera.height))
        args = (visible, options, surface, front_depths)
        stop.check()
        if len(frame_tiles) == 1:
            rgba, depth, film = self._run_tile(frame_tiles[0], *args)
            return rgba, depth, None if film is None else film.reshape(-1)
        rgba = np.empty((camera.height, camera.width, 4), np.float32)
        depth = np.empty((camera.height, camera.width), np.float32)
        film = np.empty_like(rgba) if options.film is not None else None
        for tile in frame_tiles:
            stop.check()
            x0, y0, w, h = tile
            out = (slice(y0, y0 + h), slice(x0, x0 + w))
            rgba[out], depth[out], tile_film = self._run_tile(tile, *args)
            if film is not None:  # bottom-up: the tile's rows end h - y0 rows from the top
                film[camera.height - y0 - h:camera.height - y0, x0:x0 + w] = tile_film
        return rgba, depth, None if film is None else film.reshape(-1)

    def _run_tile(self, tile, visible: int, options: RenderOptions, surface=None, front_depths=None):
        rgba, depth = self.compositor.run(tile, visible, options.early_termination, self.want_depth,
                                          options.capped_extent, surface, front_depths)
        self.stats["splat_draws"] += self.compositor.splat_draws
        self.stats["saturation_passes"] += self.compositor.breaks
        self.stats["draw_flushes"] += self.compositor.flushes
        film = None
        if options.film is not None:
            if self.film_pass is None:
                self.film_pass = FilmPass(self.ctx, "ssbo" if self.compute else "texture")
            _, _, w, h = tile
            film = self.film_pass.run(self.compositor.colour(w, h), w, h, options.film,
                                      options.background)
        return rgba, depth, film

    def last_order(self) -> np.ndarray:
        """Global indices (concatenated items) of the last frame, back to front."""
        order, visible, _ = self.last
        if order is None:
            raise RuntimeError("the GL 3.3 fallback keeps no order on the GPU")
        return np.frombuffer(order.read(size=4 * visible), np.uint32).copy() if visible else \
            np.zeros(0, np.uint32)

    def last_depths(self) -> np.ndarray:
        """Sort depth per global splat of the last frame: view depth minus the frame's
        anchor (the first item's origin depth); +inf where culled."""
        order, _, n = self.last
        if order is None and n:
            raise RuntimeError("the GL 3.3 fallback keeps no depths on the GPU")
        return np.frombuffer(self.arrays["depth"].read(size=4 * n), np.float32).copy() if n else \
            np.zeros(0, np.float32)

    def release(self):
        self.cache.release()
        for owner in (self.sorter, self.record_textures, self.compositor, self.holdout, self.film_pass):
            if owner is not None:
                owner.release()
        for buf in list(self.arrays.values()) + [self.range, self.dummy]:
            if buf is not None:
                buf.release()
        for program in self.preprocess.values():
            program.release()

    def preprocess_records(self, items, camera, options) -> dict:
        """Run only the upload and preprocess stages and read their output back, for tests
        that pin the compute shader to core/preprocess.py: (N, 4) float32 rec0, rec1, rec2 and
        the (N,) sort depth, in item order (an equirect camera's seam copies follow, one
        block of N per copy). Culled splats hold rec1 = 0, depth +inf (their rec0 and rec2
        are left as they were)."""
        n, _ = self._project(items, camera, options)
        out = {k: np.frombuffer(self.arrays[k].read(size=16 * n), np.float32).reshape(n, 4).copy()
               for k in ("rec0", "rec1", "rec2")}
        out["depth"] = np.frombuffer(self.arrays["depth"].read(size=4 * n), np.float32).copy()
        return out


def preprocess_defines(camera: Camera) -> tuple:
    """The preprocess program's constants for this camera: its projection (SL_CAMERA: 0
    perspective, 1 orthographic, 2 equirect) and depth of field (SL_DOF)."""
    kind = 2 if camera.equirect else 1 if camera.ortho else 0
    return (("SL_CAMERA", kind), ("SL_DOF", int(camera.defocus is not None)))


def tiles(width: int, height: int):
    for y0 in range(0, height, MAX_TILE):
        for x0 in range(0, width, MAX_TILE):
            yield x0, y0, min(MAX_TILE, width - x0), min(MAX_TILE, height - y0)


def behind(rgba: np.ndarray, background) -> None:
    """Put the premultiplied background behind the composited splats, in place:
    C + T bg, with T = 1 - alpha (the reference's last step)."""
    bg = np.asarray(background, np.float32)
    if bg.any():
        rgba += (1.0 - rgba[..., 3:4]) * bg
