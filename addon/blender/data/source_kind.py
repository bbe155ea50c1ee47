"""How a source of splats describes itself: one `SplatSource` row per kind of source.

A splat object's splats at a frame come from exactly one source: its stored PointCloud
attributes, a numbered sequence of files, a dynamic capture evaluated at the frame's
capture time... Each declares here what every consumer needs to know, so that none of
them recognises a source by its name or its cache key (sources.py holds the table):
- the evaluator (evaluate/items.py) asks for the splats and their key at a frame, and the
  rest centres that noise effects sample;
- the viewport redraws on a frame change where the source depends on time;
- Blender 5.3's handoff writes a companion wherever the splats are not the stored ones;
- `is_splat_object` accepts an object whose splats come from elsewhere, whatever its data.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ...core.splats import SplatSet


@dataclass(frozen=True)
class SourceFrame:
    """An object's splats at one frame, before look and effects.

    key: equal keys mean identical splats (the renderers' and evaluator's caches rely on
    it). rest: (count, 3) float32 centres that noise fields sample for these splats, splat
    for splat: where each splat sits at rest, so that a noise pattern stays attached to
    splats that move by themselves; None where the splats are at rest (their positions)."""
    splats: SplatSet
    key: tuple
    rest: np.ndarray | None = None


@dataclass(frozen=True)
class SplatSource:
    """A kind of splat source.

    applies(obj): whether the source provides this object's splats. It reads the object's
    own settings and data only (it runs in panels' polls and on every redraw), never files.
    frame(obj_eval, depsgraph): the object's splats at the depsgraph's frame.
    depends_on_time: the splats change with the frame by themselves, with no keyframe or
    edit (the viewport re-evaluates the object at every frame change).
    moves_splats: its splats' centres change from frame to frame (noise effects then sample
    the frame's `rest` centres, and the viewport re-uploads the centres it draws).
    stored: the splats are the object's own PointCloud attributes as they are stored
    (Blender 5.3's engines can draw those data themselves; any other source is handed to
    them through a companion, evaluate/native_handoff.py)."""
    id: str
    label: str
    applies: Callable[[object], bool]
    frame: Callable[[object, object], SourceFrame]
    depends_on_time: bool
    moves_splats: bool
    stored: bool = False
