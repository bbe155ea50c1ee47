"""OffscreenRenderer: the final-render path (F12, blender -b, command line).

One standalone moderngl context (EGL on Linux, also headless on CPU through Mesa
llvmpipe), created once, owned by a private thread and reused across frames, with the
splat data and frame buffers kept on the GPU between frames.
"""
from __future__ import annotations

import logging
import os
import sys

from ..core.camera import Camera
from ..core.scene import RenderItem, RenderOptions, RenderOutput
from .uniforms import slots_per_splat
from .worker import GLWorker

log = logging.getLogger(__name__)


BACKEND_ENV = "SPLATLINE_GL_BACKEND"


def _create_context():
    """A standalone context. SPLATLINE_GL_BACKEND names glcontext's backend (egl, x11,
    ...) for users whose default one misbehaves; an unknown name fails as a missing
    driver would, which the tests use to exercise the engine's fallback."""
    import moderngl

    backend = os.environ.get(BACKEND_ENV, "").strip()
    if backend:
        return moderngl.create_context(standalone=True, backend=backend, require=330)
    if sys.platform.startswith("linux"):
        return moderngl.create_context(standalone=True, backend="egl", require=330)
    return moderngl.create_context(standalone=True, require=330)


class OffscreenRenderer:
    """render(items, camera, options) -> RenderOutput: a core.renderer.Renderer.

    Same semantics as core/reference.py. Splats are composited front to back
    (gl/composite.py); options.early_termination stops a pixel at the end of the batch
    in which its transmittance fell below 1e-4 rather than at the exact splat: within
    that 1e-4 of light of the full composite, and up to 1% from the reference's exact stop
    (which leaves out the splat that would cross; bench/final_frame_bench.py measures
    both). Matches the reference to ~90-140 dB PSNR (bench/render_bench.py).

    stats counts work across frames: frames, geometry_uploads (objects whose splats
    were sent), sh_uploads, bytes_uploaded, gpu_sorts, cpu_sorts, splat_draws (batches of
    splats drawn), saturation_passes (early-termination passes between them: saturation
    map builds, or on GL 3.3 depth marks; with a holdout on the compute path the batches
    run even with early termination off), draw_flushes (glFlush calls between a batch's chunks, software GL only),
    holdout_uploads (holdouts whose triangles were sent: once per Holdout.key);
    resident_objects is how many objects hold GPU buffers after the last frame.

    options.holdout (a core.holdout.Holdout) hides the splats behind its triangles, per
    fragment, as the reference does (gl/holdout.py).
    """

    has_holdout = has_panorama = has_defocus = has_early_termination = has_film = True

    def __init__(self, context_factory=_create_context, depth_pass: bool = True,
                 compute: bool | None = None):
        """depth_pass=False leaves out the Z attachment (RenderOutput.depth: one more
        RGBA32F target blended in the same draws) and returns depth filled with +inf.
        compute=None uses compute shaders (GPU preprocess, GPU or CPU sort, cached
        uploads) where GL >= 4.3; compute=False, or an older GL, takes the GL 3.3
        fallback: CPU preprocess and sort (core/preprocess.py, core/sort.py), GPU draw."""
        self.stats = {"frames": 0, "geometry_uploads": 0, "sh_uploads": 0,
                      "bytes_uploaded": 0, "gpu_sorts": 0, "cpu_sorts": 0,
                      "splat_draws": 0, "saturation_passes": 0, "draw_flushes": 0,
                      "holdout_uploads": 0, "resident_objects": 0}
        self.has_depth = bool(depth_pass)
        self._worker = GLWorker(context_factory)
        from .frame import FrameState

        try:
            self._state = self._worker.call(FrameState, self._worker.ctx, self.stats, compute)
            self._state.want_depth = bool(depth_pass)
        except BaseException:
            self._worker.close()
            raise
        self.gl_info = self._worker.call(lambda: dict(self._worker.ctx.info))
        self._large = None  # the GL 3.3 state for frames past the storage-block limit
        self._last = self._state

    def render(self, items: list[RenderItem], camera: Camera,
               options: RenderOptions = RenderOptions()) -> RenderOutput:
        items = list(items)
        slots = sum(item.splats.count for item in items) * slots_per_splat(camera)
        self._last = self._state_for(slots)
        return self._worker.call(self._last.render, items, camera, options)

    def _state_for(self, count: int):
        """The compute path, or for a frame past its storage-block limit the GL 3.3 path
        (records in textures, CPU sort): a large scene renders instead of failing with
        advice a user of F12 cannot act on. Said once in the log."""
        if not self._state.compute or count <= self._state.record_limit:
            return self._state
        if self._large is None:
            from .frame import FrameState

            self._large = self._worker.call(FrameState, self._worker.ctx, self.stats, False)
            self._large.want_depth = self._state.want_depth
            log.warning("Splatline: %s splats in one frame exceed this GPU's storage blocks "
                        "(%s); rendering such frames on the GL 3.3 path (CPU sort, slower)",
                        f"{count:,}", f"{self._state.record_limit:,}")
        return self._large

    def holdout_depth(self, holdout, camera: Camera):
        """The (H, W) float32 surface depth map the draw stage tests the splats against
        (+inf where no surface), for tests: core.holdout.holdout_depth in float32. Drawn
        as one tile (frames up to 4096 on a side)."""
        return self._worker.call(self._state.holdout.read, holdout, camera)

    def last_order(self):
        """Back-to-front global splat indices of the last frame (for tests and tools)."""
        return self._worker.call(self._last.last_order)

    def last_depths(self):
        """Per-splat sort depths of the last frame (view depth minus an anchor), +inf where culled."""
        return self._worker.call(self._last.last_depths)

    def close(self):
        """Release every GPU object and the context, and join the GL thread."""
        large = self._large

        def release():
            self._state.release()
            if large is not None:
                large.release()

        self._worker.close(release)

    @property
    def uses_compute(self) -> bool:
        """True on the GL 4.3 compute path, False on the GL 3.3 fallback."""
        return self._state.compute

    @property
    def closed(self) -> bool:
        return not self._worker.alive

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
