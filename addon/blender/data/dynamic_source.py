"""The dynamic-capture source: splats that move, turn and fade by themselves (a 4D capture),
evaluated at the capture time the timeline maps the frame to (its row of the source table,
sources.py, is `ROW`).

A dynamic capture is one PointCloud object. Its splat attributes hold every splat at rest
(its centre at its own time centre, base opacity: core.dynamic's `rest()`), so every tool
that reads splat attributes sees the capture; `dynamic:*` point attributes hold the time
model's own fields, and `Object.splatline.dynamic` its time range and the timeline mapping.
Saved in the .blend, it needs no file to play, like any imported capture.
"""
from __future__ import annotations

import threading

import numpy as np

import bpy

from ...core.dynamic import timeline
from ...core.dynamic.capture import DynamicCapture
from ...core.splats import SplatSet
from ..registration import app_handlers
from . import stored_splats
from .evaluated_geometry import own_data
from .pointcloud import read_floats, write_floats
from .source_kind import SourceFrame, SplatSource

PREFIX = "dynamic:"
SEGMENTS = "splatline_dynamic_segments"  # on the PointCloud: segment k's first splat, and N
UNITS = {"segment": timeline.SEGMENT, "seconds": timeline.SECONDS}


def settings_of(obj):
    return getattr(getattr(obj, "splatline", None), "dynamic", None)


def plays_dynamic(obj) -> bool:
    dynamic = settings_of(obj)
    return bool(getattr(dynamic, "enabled", False)) and stored_splats.holds_splats(obj)


def fields_of(capture: DynamicCapture) -> dict[str, np.ndarray]:
    """The time model's arrays beyond the rest splats, by attribute name."""
    fields = {f"motion_{d}": capture.motion[:, d] for d in range(capture.motion.shape[1])}
    fields.update(t_center=capture.t_center, t_scale=capture.t_scale,
                  rotation=capture.rotations)  # as stored: omega is added before normalising
    if capture.omega is not None:
        fields["omega"] = capture.omega
    if capture.window is not None:
        fields["window"] = capture.window.astype(np.float32)
    return fields


def store(obj, capture: DynamicCapture, frames_per_unit: float, start_frame: float) -> None:
    """Write the capture's time model onto a new splat object holding `capture.rest()`."""
    attributes = obj.data.attributes
    for name, values in fields_of(capture).items():
        write_floats(attributes, PREFIX + name, values)
    obj.data[SEGMENTS] = [int(x) for x in capture.segment_offsets]
    dynamic = obj.splatline.dynamic
    dynamic.model = capture.model
    dynamic.unit = UNITS[capture.unit]
    dynamic.time_start, dynamic.time_end = capture.t_start, capture.t_end
    dynamic.cutoff = capture.cutoff if capture.cutoff is not None else 0.0
    dynamic.frames_per_unit, dynamic.start_frame = frames_per_unit, start_frame
    dynamic.enabled = True


def read_capture(pointcloud, rest: SplatSet, dynamic) -> DynamicCapture:
    """The DynamicCapture a PointCloud stores (store's inverse), around its rest splats."""
    n, attributes = rest.count, pointcloud.attributes

    def field(name, width):
        return read_floats(attributes, PREFIX + name, width, n)

    depth = sum(1 for d in range(3) if f"{PREFIX}motion_{d}" in attributes)
    motion = np.stack([field(f"motion_{d}", 3) for d in range(depth)], axis=1)
    window = field("window", 2).astype(np.float64) if PREFIX + "window" in attributes else None
    omega = field("omega", 4) if PREFIX + "omega" in attributes else None
    unit = next(k for k, v in UNITS.items() if v == dynamic.unit)
    offsets = np.asarray(pointcloud.get(SEGMENTS, [0, n]), np.int64)
    return DynamicCapture(
        model=dynamic.model, positions=rest.positions, motion=motion, rotations=field("rotation", 4),
        omega=omega, scales=rest.scales, opacities=rest.opacities, sh_dc=rest.sh_dc,
        sh_rest=rest.sh_rest, t_center=field("t_center", 1), t_scale=field("t_scale", 1),
        window=window, cutoff=dynamic.cutoff if dynamic.model == "4dgs" else None, axes=rest.axes,
        t_start=dynamic.time_start, t_end=dynamic.time_end, unit=unit, segment_offsets=offsets)


class CaptureCache:
    """DynamicCaptures read back from PointClouds, keyed by the stored source's base key
    (equal keys, identical data), so a frame change costs the evaluation alone."""

    def __init__(self):
        self.lock = threading.Lock()
        self.entries: dict[tuple, tuple] = {}

    def get(self, obj_eval, depsgraph) -> tuple[DynamicCapture, tuple]:
        rest, key = stored_splats.CACHE.get(obj_eval, depsgraph)
        dynamic = settings_of(obj_eval)
        full = (key, dynamic.model, dynamic.unit, dynamic.time_start, dynamic.time_end,
                dynamic.cutoff)
        with self.lock:
            hit = self.entries.get(key[0])
        if hit is None or hit[0] != full:
            hit = (full, read_capture(own_data(obj_eval, depsgraph), rest, dynamic))
            with self.lock:
                self.entries[key[0]] = hit
        return hit[1], full

    def clear(self) -> None:
        with self.lock:
            self.entries.clear()


CACHE = CaptureCache()


def capture_time(obj_eval, depsgraph) -> float:
    return timeline.capture_time(settings_of(obj_eval).mapping(), depsgraph.scene_eval.frame_float)


def _source_frame(obj_eval, depsgraph) -> SourceFrame:
    capture, key = CACHE.get(obj_eval, depsgraph)
    t = capture_time(obj_eval, depsgraph)
    frame = capture.at(t)
    # every splat alive: the rest centres are the capture's own array, the same each frame,
    # so the noise fields sampled at them are memoized across frames
    everyone = frame.alive == capture.count
    rest = capture.rest_positions if everyone else capture.rest_positions[frame.index]
    return SourceFrame(frame.splats, ("dynamic", key, t), rest=rest)


ROW = SplatSource("DYNAMIC", "Dynamic Capture", plays_dynamic, _source_frame,
                  depends_on_time=True, moves_splats=True)


@bpy.app.handlers.persistent
def _on_load(*_args):
    CACHE.clear()


register, unregister = app_handlers(((bpy.app.handlers.load_pre, _on_load),), on_unregister=CACHE.clear)
