"""The viewport's view-dependent CPU work: frustum culling and the global back-to-front
order of several objects' splats, and the worker thread that computes it off the drawing
thread. Pure (numpy, threading); blender/viewport/viewport_renderer.py drives it.

All objects are sorted together, so overlapping objects interleave correctly.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np

from .sort import far_to_near


class LazyArray:
    """fn(source), made on first use by whichever thread sorts first: with the sort on the
    worker, an effect's new centres or sizes are laid out for it there, not on the drawing
    thread. Two threads racing make the same array twice, harmlessly."""

    def __init__(self, fn, source):
        self.fn, self.source, self._value = fn, source, None

    @property
    def value(self) -> np.ndarray:
        if self._value is None:
            self._value = self.fn(self.source)
        return self._value

    @property
    def nbytes(self) -> int:
        return 0 if self._value is None else self._value.nbytes


def _array(a):
    return a.value if isinstance(a, LazyArray) else a


@dataclass
class SortInput:
    """One object's part of the sort: centres, bounding radii and where they are placed."""

    soa: np.ndarray | LazyArray   # (3, N) float32 centres, object space, one row per axis
    local_to_camera: np.ndarray  # (4, 4) float64 (Blender camera: looks down -z)
    cull: bool = True
    dilation: float = 0.2        # frustum grown by this fraction of its half-size
    radius_scale: float = 1.0    # splat scale multipliers applied to the radii
    radius: np.ndarray | LazyArray | None = None  # (N,) float32 bounding radius (bounding_radius)

    @staticmethod
    def of(positions: np.ndarray, local_to_camera, cull: bool = True, dilation: float = 0.2,
           scales: np.ndarray | None = None):
        radius = None if scales is None else bounding_radius(scales)
        return SortInput(centres_layout(positions), local_to_camera, cull, dilation, 1.0, radius)


def centres_layout(positions: np.ndarray) -> np.ndarray:
    """(3, N) float32: one contiguous row per axis, so every culling test streams."""
    return np.ascontiguousarray(np.asarray(positions, np.float32).T)


# The exact footprint reaches sqrt(2 ln(255 o)) sigma: 3.33 at o = 1, 3.96 at the Look's
# largest opacity multiplier (10). Culling must not drop a splat whose faint ring shows.
FOOTPRINT_SIGMAS = 4.0


def bounding_radius(scales: np.ndarray) -> np.ndarray:
    """(N,) float32: the footprint bound (FOOTPRINT_SIGMAS) of each splat's largest
    axis (NaN/inf stay: the shader culls them)."""
    s = np.asarray(scales, np.float32)
    r = np.maximum(s[:, 0], s[:, 1])
    np.maximum(r, s[:, 2], out=r)
    r *= np.float32(FOOTPRINT_SIGMAS)
    return r


@dataclass
class SortResult:
    order: np.ndarray        # (M,) uint32 global splat indices, farthest first
    seconds: float           # wall time of the cull + sort
    token: object = None     # what the caller asked for (view + data versions)
    radius_dependent: bool = False  # the frustum test removed splats: other radii may not
    cpu_seconds: float = 0.0  # the sorting thread's CPU time (a loaded machine adds wall time only)
    layout: object = None    # the caller's name for the splats the indices index


def _rows(m: np.ndarray, projection: np.ndarray, cull: bool) -> np.ndarray:
    """Affine rows (k, 4) taking local points to: view depth [, x_clip, y_clip [, w_clip]].

    w_clip is left out when it equals the view depth (any perspective projection).
    """
    depth = -m[2]
    if not cull:
        return depth[None]
    pm = projection @ m
    if np.allclose(projection[3], (0.0, 0.0, -1.0, 0.0)):
        return np.stack([depth, pm[0], pm[1]])
    return np.stack([depth, pm[0], pm[1], pm[3]])


SAMPLE_STRIDE = 64     # culling first looks at every 64th splat ...
CULL_WORTH = 0.1       # ... and culls them all only if more than this fraction would go
SMALL = 4096           # below this many splats, always cull (it costs next to nothing)


def affine_row(row: np.ndarray, soa: np.ndarray) -> np.ndarray:
    """row[:3] . point + row[3] for each column of soa, in float32, as three scaled adds:
    a matrix product here would go to BLAS, whose threads then spin on a core for a while
    after every call, taking it from the drawing thread and the effects."""
    out = soa[0] * np.float32(row[0])
    out += soa[1] * np.float32(row[1])
    out += soa[2] * np.float32(row[2])
    out += np.float32(row[3])
    return out


def _outside(soa: np.ndarray, depth: np.ndarray, radius, rows: np.ndarray, dilation: float,
             radius_scale: float) -> np.ndarray:
    """Mask of splats whose bounding sphere lies wholly outside the grown frustum.

    rows: depth, x_clip, y_clip [, w_clip] (see _rows); depth: rows[0] at these points,
    already made by the caller (w_clip itself, for a perspective view). A sphere of radius
    R moves x_clip and w by at most |row| R, so |x| <= grow * w is relaxed by R * reach.
    """
    grow = 1.0 + dilation
    w_row = rows[3] if rows.shape[0] == 4 else rows[0]
    reach = max(np.linalg.norm(rows[1, :3]), np.linalg.norm(rows[2, :3])) + grow * np.linalg.norm(w_row[:3])
    if rows.shape[0] == 4:
        lim = affine_row(w_row, soa)
        lim *= np.float32(grow)
    else:
        lim = depth * np.float32(grow)
    if radius is not None:
        lim += radius * np.float32(radius_scale * reach)
    m = affine_row(rows[1], soa)
    np.abs(m, out=m)
    y = affine_row(rows[2], soa)
    np.maximum(m, np.abs(y, out=y), out=m)
    return m > lim


def _keep(part: SortInput, projection, near, far):
    """(depths, indices or None for all, whether the frustum test removed any) of one
    object's splats that survive culling.

    Culling is conservative: a splat goes only when its bounding sphere (4 sigma of
    its largest axis) lies wholly outside the grown frustum, so a large splat whose
    centre is off-screen but whose body covers the view is kept; culled splats would
    have drawn nothing. It is skipped when a sample says it would remove too few to
    pay for itself. The near and far tests use the centre, as every renderer does.
    """
    m = np.asarray(part.local_to_camera, np.float64)
    soa = _array(part.soa)
    depth = affine_row(-m[2], soa)
    keep = depth > near
    keep &= depth <= far
    frustum_removed = False
    if part.cull:
        rows = _rows(m, projection, True)
        n = soa.shape[1]
        r = _array(part.radius)
        args = (rows, part.dilation, part.radius_scale)
        every = slice(None, None, SAMPLE_STRIDE)
        if n <= SMALL or _outside(soa[:, every], depth[every], None if r is None else r[every],
                                  *args).mean() > CULL_WORTH:
            outside = _outside(soa, depth, r, *args)
            frustum_removed = bool((outside & keep).any())
            keep &= ~outside
    if keep.all():
        return depth, None, frustum_removed
    idx = np.flatnonzero(keep).astype(np.int32)  # half the bytes for the gathers that follow
    return depth[idx], idx, frustum_removed


def visible_order(inputs: list[SortInput], projection: np.ndarray, near: float, far: float,
                  bits: int = 16) -> SortResult:
    """Indices into the concatenation of every input's splats, farthest first.

    Kept: centres with near < depth <= far and, when culling, inside the frustum
    grown by `dilation` (|x|, |y| <= (1 + dilation) w in clip space).
    """
    start, cpu = time.perf_counter(), time.thread_time()
    depths, indices = [], []
    offset = 0
    radius_dependent = False
    projection = np.asarray(projection, np.float64)
    for part in inputs:
        depth, idx, frustum_removed = _keep(part, projection, near, far)
        radius_dependent |= frustum_removed
        n = _array(part.soa).shape[1]
        if idx is None and len(inputs) > 1:
            idx = np.arange(n, dtype=np.int32)
        depths.append(depth)
        indices.append(idx if idx is None or not offset else idx + np.int32(offset))
        offset += n
    if not depths:
        return SortResult(np.zeros(0, np.uint32), time.perf_counter() - start,
                          cpu_seconds=time.thread_time() - cpu)
    depth = np.concatenate(depths) if len(depths) > 1 else depths[0]
    order = far_to_near(depth, bits)
    if indices[0] is not None or len(indices) > 1:
        index = np.concatenate(indices) if len(indices) > 1 else indices[0]
        order = index.view(np.uint32)[order]  # int32 indices, all >= 0: the same bits
    return SortResult(order, time.perf_counter() - start, radius_dependent=radius_dependent,
                      cpu_seconds=time.thread_time() - cpu)


class SortWorker:
    """One background thread that runs the latest requested sort.

    Double buffering: the draw thread keeps drawing with the order it already
    uploaded while the worker sorts for the newest view; a request made while the
    worker is busy replaces any older pending one (only the latest view matters).
    `on_done` is called from the worker thread, so it must only set flags.
    """

    def __init__(self, on_done=None, name: str = "splatline-sort"):
        self._cond = threading.Condition()
        self._pending = None
        self._ready: SortResult | None = None
        self._busy = False
        self._stop = False
        self._on_done = on_done
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def request(self, token, inputs, projection, near, far, bits, layout=None) -> None:
        with self._cond:
            self._pending = ((token, layout), inputs, projection, near, far, bits)
            self._cond.notify()

    def take(self) -> SortResult | None:
        """The newest finished result not yet taken, or None."""
        with self._cond:
            result, self._ready = self._ready, None
            return result

    @property
    def idle(self) -> bool:
        with self._cond:
            return self._pending is None and not self._busy

    def _run(self):
        while True:
            with self._cond:
                while self._pending is None and not self._stop:
                    self._cond.wait()
                if self._stop:
                    return
                job, self._pending = self._pending, None
                self._busy = True
            (token, layout), *args = job
            try:
                result = visible_order(*args)
                result.token, result.layout = token, layout
            except Exception:  # a bad frame must not kill the worker; the draw re-sorts inline
                result = None
            with self._cond:
                self._busy = False
                if result is not None:
                    self._ready = result
            if result is not None and self._on_done is not None:
                self._on_done()

    def stop(self) -> None:
        with self._cond:
            self._stop = True
            self._cond.notify()
        self._thread.join(timeout=5.0)

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()
