"""Stage "holdout" (issue 25): meshes hide splats, per fragment, as core/holdout.py says.

Before a tile's splats are composited, the holdout's triangles are drawn into an R32F
target the size of the tile: the depth of the nearest surface under each pixel centre,
+inf where none, in the splats' own measure (view depth -z; for an equirect camera the
distance). Each triangle is one instanced quad over its screen box (gl_holdout.vert), and
the fragment stage casts the pixel-centre ray against it exactly (gl_holdout.frag,
Moeller-Trumbore in float32, camera-relative) and keeps the nearest hit through MIN
blending: no depth buffer and no non-linear z, the same rays for all three cameras, so
the map equals core.holdout.holdout_depth up to float32 rounding (tests/gl/test_gl_holdout.py).
Drawing the triangles themselves instead (GL's coverage, the ray only for the depth)
was a little faster but left holes: the rasteriser snaps corners to 1/256 pixel, so a
pixel centre that close to an edge two triangles share may go to the one whose exact
test then misses it (32 pixels of the 1080p bench frame); over the boxes every
triangle tests every pixel it may hold, and none differs from the reference's coverage.
With depth of field it is the pinhole's map, as the reference's.

The compositor (gl/composite.py) then writes the tile's map into a depth buffer,
linearly encoded over the depths where splats and surface overlap
(gl_holdout_resolve.frag), and the draw stage's SL_HOLDOUT variant puts each quad at
its centre depth, encoded alike and raised by a bias above the encodings' rounding
(gl_splat.vert): the early depth test (LESS, no writes) then drops every fragment whose
centre is not in front of the surface there, before its shader runs, and never keeps one
behind it; a fragment within 2.4e-6 of that depth span in front of the surface may be
dropped with them (held_band: 4.3 um on the bench frame, 1.85 m of overlap). A dropped
fragment adds no alpha, so it never counts toward saturation. With a surface among the
splats' depths that covers no pixel (every cost, nothing hidden), a per-fragment read of
the map instead cost 1.4x the bench frame's time (llvmpipe: a gather per lane, with or
without a branch around it), the depth test 1.10-1.16x.
On the compute path the batches also cull: each batch's smallest centre depth is gathered
first (gl_holdout_minima.comp, with the frame's largest, the encoding's range), and
before each later batch a cell is closed too where its surface lies at or in front of
every splat still to be drawn (exact: all their fragments there would be dropped), so
splats behind a mesh are dropped in the vertex stage (0.83x the bench frame's time
without this culling, A/B in one process). With early termination off the
batches run as well, closing cells only by the surface. On GL 3.3 the depth test does it
alone; its saturation marks go to depth 0, below every encoded splat.
Frames without a holdout, or whose surfaces all lie behind every splat, run the compositor's
plain programs unchanged.

Triangles are uploaded once per Holdout.key, relative to their mean (float64 on the
CPU), so a mesh far from the origin keeps its float32 precision near the camera; the
camera's transform is a uniform. The few most recent holdouts stay resident (an animated
mesh gives a new key each frame, a motion-blurred one each sub-frame).
"""
from __future__ import annotations

from collections import OrderedDict

import moderngl
import numpy as np

from ..core.camera import Camera
from . import shaders
from .uniforms import set_uniform

KEEP = 4  # holdouts whose triangles stay on the GPU (most recently used)
# the depth encoding of holdout frames (gl_splat.vert, gl_holdout_resolve.frag): the
# overlap of splat and surface depths maps to [ENC_BASE, ENC_BASE + ENC_SPAN] of the
# 24-bit depth buffer; quads are raised by HOLDOUT_BIAS, over twice the rounding of the
# two encodings, the viewport transform and the buffer's 2^-24 steps (7.5 x 2^-24 at most)
ENC_BASE, ENC_SPAN = 1 / 16, 13 / 16
HOLDOUT_BIAS = 2.0 ** -20


def active(options):
    """The frame's Holdout where it has triangles, else None (no holdout work at all)."""
    holdout = getattr(options, "holdout", None)
    return holdout if holdout is not None and holdout.count > 0 else None


def depth_bounds(holdout, camera: Camera) -> tuple[float, float]:
    """(lo, hi) float64 bounds of every depth at which a pixel-centre ray can hit the
    triangles (near < depth <= far), over the triangles that can reach the frame at all;
    (inf, -inf) where none can (then the compositor runs the plain programs: a mesh out of
    view costs nothing). Perspective and orthographic: depth is linear over a triangle,
    so it lies between its corners'; a triangle whose corners all lie in front of the
    clip start projects inside their screen box (one reaching behind the camera counts
    as in view). Equirect (distance): at most the farthest corner's, at least the nearest
    corner's minus the longest edge; every triangle counts as in view. Per frame on the
    CPU: ~0.1 s for a million triangles on the bench machine."""
    m = np.asarray(camera.world_to_camera, np.float64)
    corners = holdout.triangles.reshape(-1, 3)
    x, y, z = ((corners @ m[k, :3] + m[k, 3]).reshape(-1, 3) for k in range(3))
    lo3 = lambda a: np.minimum(np.minimum(a[:, 0], a[:, 1]), a[:, 2])
    hi3 = lambda a: np.maximum(np.maximum(a[:, 0], a[:, 1]), a[:, 2])
    if camera.equirect:
        d = np.sqrt(x * x + y * y + z * z)
        edge = [np.sqrt((x[:, a] - x[:, b]) ** 2 + (y[:, a] - y[:, b]) ** 2 + (z[:, a] - z[:, b]) ** 2)
                for a, b in ((0, 1), (1, 2), (2, 0))]
        low, high = lo3(d) - np.maximum(np.maximum(*edge[:2]), edge[2]), hi3(d)
        seen = True
    else:
        d = -z
        low, high = lo3(d), hi3(d)
        with np.errstate(all="ignore"):
            if camera.ortho:
                u, v = camera.cx + camera.fx * x, camera.cy - camera.fy * y
            else:
                u, v = camera.cx + camera.fx * x / d, camera.cy - camera.fy * y / d
            seen = ((hi3(u) >= -1.0) & (lo3(u) <= camera.width + 1.0)
                    & (hi3(v) >= -1.0) & (lo3(v) <= camera.height + 1.0))
        if not camera.ortho:
            seen |= low <= camera.near
    live = seen & (high > camera.near) & (low <= camera.far)
    if not live.any():
        return np.inf, -np.inf
    return (float(max(low[live].min(), camera.near)), float(min(high[live].max(), camera.far)))


class Surface:
    """A frame's holdout for the compositor: its depth bounds (depth_bounds) and its
    map of a tile, drawn when the compositor asks (not at all where every surface lies
    behind every splat)."""

    def __init__(self, holdout_pass, holdout, camera: Camera):
        self.bounds = depth_bounds(holdout, camera)
        self._pass, self._holdout, self._camera = holdout_pass, holdout, camera

    def draw(self, tile):
        return self._pass.render(self._holdout, self._camera, tile)


def camera_kind(camera: Camera) -> int:
    """SL_CAMERA: 0 perspective, 1 orthographic, 2 equirect (as the preprocess's)."""
    return 2 if camera.equirect else 1 if camera.ortho else 0


class _Upload:
    def __init__(self, ctx, holdout):
        tri = np.asarray(holdout.triangles, np.float64)
        self.origin = tri.reshape(-1, 3).mean(0)
        local = (tri - self.origin).astype(np.float32)
        self.buffer = ctx.buffer(np.ascontiguousarray(local).tobytes())
        self.count = holdout.count
        self.nbytes = local.nbytes
        self.vaos = {}

    def vao(self, ctx, program):
        if program not in self.vaos:
            self.vaos[program] = ctx.vertex_array(
                program, [(self.buffer, "3f 3f 3f/i", "a_v0", "a_v1", "a_v2")])
        return self.vaos[program]

    def release(self):
        for vao in self.vaos.values():
            vao.release()
        self.buffer.release()


class HoldoutPass:
    """Owns the holdout programs, the uploaded triangles and the tile targets (GL thread)."""

    def __init__(self, ctx, stats: dict, version: int = 330):
        self.ctx = ctx
        self.stats = stats
        self.version = version
        self.programs: dict = {}
        self.uploads: OrderedDict = OrderedDict()
        self.targets: dict = {}

    def _program(self, kind: int):
        if kind not in self.programs:
            records = "ssbo" if self.version >= 430 else "texture"
            defines = {"SL_CAMERA": kind}
            self.programs[kind] = self.ctx.program(
                vertex_shader=shaders.source("gl_holdout.vert", math=False, defines=defines,
                                             records=records),
                fragment_shader=shaders.source("gl_holdout.frag", math=False, defines=defines,
                                               records=records))
        return self.programs[kind]

    def _upload(self, holdout) -> _Upload:
        up = self.uploads.get(holdout.key)
        if up is None:
            up = _Upload(self.ctx, holdout)
            self.uploads[holdout.key] = up
            self.stats["holdout_uploads"] = self.stats.get("holdout_uploads", 0) + 1
            self.stats["bytes_uploaded"] += up.nbytes
            while len(self.uploads) > KEEP:
                self.uploads.popitem(last=False)[1].release()
        else:
            self.uploads.move_to_end(holdout.key)
        return up

    def _target(self, w: int, h: int):
        if (w, h) not in self.targets:
            tex = self.ctx.texture((w, h), 1, dtype="f4")
            tex.filter = moderngl.NEAREST, moderngl.NEAREST
            self.targets[(w, h)] = (tex, self.ctx.framebuffer([tex]))
        return self.targets[(w, h)]

    def render(self, holdout, camera: Camera, tile):
        """Draw the holdout's depth map of one (x0, y0, w, h) tile; returns its texture."""
        x0, y0, w, h = tile
        tex, fbo = self._target(w, h)
        up = self._upload(holdout)
        prog = self._program(camera_kind(camera))
        m = np.asarray(camera.world_to_camera, np.float64)
        set_uniform(prog, "u_rot", m[:3, :3])
        set_uniform(prog, "u_offset", tuple(float(v) for v in m[:3, :3] @ up.origin + m[:3, 3]))
        set_uniform(prog, "u_focal_centre", (camera.fx, camera.fy, camera.cx, camera.cy))
        set_uniform(prog, "u_near_far", (float(camera.near), float(camera.far)))
        set_uniform(prog, "u_tile", (float(x0), float(y0), float(w), float(h)))
        fbo.use()
        fbo.viewport = (0, 0, w, h)
        fbo.clear(np.inf, np.inf, np.inf, np.inf)
        ctx = self.ctx
        ctx.enable(moderngl.BLEND)
        ctx.blend_equation = moderngl.MIN
        vao = up.vao(ctx, prog)
        period = 2.0 * np.pi * camera.fx
        for shift in ((0.0, period, -period) if camera.equirect else (0.0,)):
            set_uniform(prog, "u_shift", float(shift))
            vao.render(moderngl.TRIANGLE_STRIP, vertices=4, instances=up.count)
        ctx.blend_equation = moderngl.FUNC_ADD
        ctx.disable(moderngl.BLEND)
        return tex

    def read(self, holdout, camera: Camera) -> np.ndarray:
        """(H, W) float32 depth map of the whole frame (one tile), for tests."""
        tex = self.render(holdout, camera, (0, 0, camera.width, camera.height))
        out = np.empty((camera.height, camera.width), np.float32)
        tex.read_into(out)
        return out

    def release(self):
        for up in self.uploads.values():
            up.release()
        self.uploads.clear()
        for tex, fbo in self.targets.values():
            fbo.release()
            tex.release()
        self.targets.clear()
        for prog in self.programs.values():
            prog.release()
        self.programs.clear()


def from_ordered_bits(bits: np.ndarray) -> np.ndarray:
    """gl_holdout_minima.comp's order-preserving uint bits back to float32."""
    bits = np.asarray(bits, np.uint32)
    raw = np.where(bits & 0x80000000, bits & 0x7FFFFFFF, ~bits).astype(np.uint32)
    return raw.view(np.float32)


def held_band(enc) -> float:
    """Depth below a surface within which a splat fragment, though in front of it, may be
    dropped by a holdout frame's depth test (and no fragment behind it is ever kept):
    bias plus rounding, under 2^-19 of the encoding, 2.4e-6 of the overlap's depth span."""
    return 2.0 * HOLDOUT_BIAS / enc[1]


def depth_encoding(near: float, far: float, lo: float, hi: float):
    """(lo, scale) of the linear depth encoding of a holdout frame, or None where the
    surface cannot hide any splat. near, far: the splats' least and largest centre
    depths; lo, hi: bounds of the surface's hit depths (gl/holdout.depth_bounds). The
    overlap [max(near, lo), min(far, hi)] maps to [ENC_BASE, ENC_BASE + ENC_SPAN] of the
    24-bit depth buffer; depths outside it compare the same way after clamping (a surface
    nearer than every splat hides them all, one farther than every splat none)."""
    if not lo <= far:  # every surface behind every splat (or none at all)
        return None
    a, b = max(near, lo), min(far, hi)
    span = b - a
    if not span > 0.0:  # the surfaces all in front of the splats, or one depth: any scale
        span = max(far - near, abs(a) * 1e-3, 1e-6)
    return (float(a), float(ENC_SPAN / span))
