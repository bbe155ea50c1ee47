"""Dynamic captures (4D Gaussian splats): a time model, its files, and the scene-time mapping.

    from addon.core.dynamic import read_dynamic, write_dynamic, is_dynamic_file, reference_at
    capture = read_dynamic("segment.ply")          # or [paths] of Spacetime segments
    frame = capture.at(t)                         # Frame: .splats (SplatSet), .index (into capture)
    rest = capture.rest_positions[frame.index]    # each kept splat's rest centre
    t = timeline.capture_time(timeline.Mapping(capture.t_start, capture.t_end), frame_number)

docs/dynamic.md describes the time model; docs/formats.md the files.
"""
from __future__ import annotations

from . import timeline
from .capture import ALPHA_MIN, MODELS, UNITS, DynamicCapture, Frame
from .convert import bake, from_fourdgs_arrays, to_fourdgs, to_fourdgs_arrays, to_linear, to_spacetime
from .files import is_dynamic_file, read_dynamic, write_dynamic
from .reference import ReferenceFrame, reference_at

__all__ = [
    "ALPHA_MIN", "MODELS", "UNITS", "DynamicCapture", "Frame", "ReferenceFrame", "bake", "from_fourdgs_arrays",
    "is_dynamic_file", "read_dynamic", "reference_at", "timeline", "to_fourdgs", "to_fourdgs_arrays",
    "to_linear", "to_spacetime", "write_dynamic",
]
