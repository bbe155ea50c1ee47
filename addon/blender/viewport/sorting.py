"""View-dependent work on the CPU: frustum culling and the global back-to-front order.

No bpy, no gpu: the draw thread and the sort worker thread both call `visible_order`.
All objects are sorted together, so overlapping objects interleave correctly.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np

from ...core.sort import far_to_near


@dataclass
class SortInput:
    """One object's part of the sort: positions and the matrices that place them."""

    positions: np.ndarray    # (N, 3) float32, object space
    local_to_camera: np.ndarray  # (4, 4) float64 (Blender camera: looks down -z)
    cull: bool = True
    dilation: float = 0.2    # frustum grown by this fraction of its half-size


@dataclass
class SortResult:
    order: np.ndarray        # (M,) uint32 global splat indices, farthest first
    seconds: float           # CPU time of the cull + sort
    token: object = None     # what the caller asked for (view + data versions)


def _clip_rows(m: np.ndarray, projection: np.ndarray) -> np.ndarray:
    """(4, 4): local -> (x_clip, y_clip, w_clip, view depth)."""
    pm = projection @ m
    return np.stack([pm[0], pm[1], pm[3], -m[2]])


def visible_order(inputs: list[SortInput], projection: np.ndarray, near: float, far: float,
                  bits: int = 16) -> SortResult:
    """Indices into the concatenation of every input's splats, farthest first.

    Kept: centres with near < depth <= far and, when culling, inside the frustum
    grown by `dilation` (splats poking in from outside keep their centre outside).
    """
    start = time.perf_counter()
    depths, indices = [], []
    offset = 0
    projection = np.asarray(projection, np.float64)
    for part in inputs:
        n = part.positions.shape[0]
        rows = _clip_rows(np.asarray(part.local_to_camera, np.float64), projection)
        a = rows[:, :3].T.astype(np.float32)
        if not part.cull:
            a, b = a[:, 3:], np.float32(rows[3, 3])
        else:
            b = rows[:, 3].astype(np.float32)
        q = part.positions @ a
        q += b
        depth = q[:, -1]
        keep = (depth > near) & (depth <= far)
        if part.cull:
            lim = np.abs(q[:, 2]) * np.float32(1.0 + part.dilation)
            keep &= (np.abs(q[:, 0]) <= lim) & (np.abs(q[:, 1]) <= lim)
        idx = np.flatnonzero(keep)
        depths.append(depth[idx])
        indices.append(idx + offset if offset else idx)
        offset += n
    if not depths:
        return SortResult(np.zeros(0, np.uint32), time.perf_counter() - start)
    depth = np.concatenate(depths) if len(depths) > 1 else depths[0]
    index = np.concatenate(indices) if len(indices) > 1 else indices[0]
    order = index[far_to_near(depth, bits)].astype(np.uint32)
    return SortResult(order, time.perf_counter() - start)


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

    def request(self, token, inputs, projection, near, far, bits) -> None:
        with self._cond:
            self._pending = (token, inputs, projection, near, far, bits)
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
            token, *args = job
            try:
                result = visible_order(*args)
                result.token = token
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
