"""The viewport's light table (no bpy, no gpu): the scene's lights, World colour and scene
camera as texels in the view's camera space, appended to the per-object table for the
preprocess pass to light splats with (shaders/viewport_lighting.glsl, which holds the
layout). Camera space because the pass has each splat's centre there already; lights
follow the view then, and the table is uploaded again whenever the view changes, as the
objects' rows are."""
from __future__ import annotations

import numpy as np

from ...core.lighting.shade import Lighting

KINDS = {"SUN": 0, "POINT": 1, "SPOT": 2, "AREA": 3}
HEAD_TEXELS = 2
LIGHT_TEXELS = 4


def light_rows(lighting: Lighting | None, view: np.ndarray) -> np.ndarray:
    """(HEAD_TEXELS + LIGHT_TEXELS x lights, 4) float32; no lighting: the head, no lights.
    view: world -> camera, rigid (a 3D view's or a camera's)."""
    lights = () if lighting is None else lighting.lights
    rows = np.zeros((HEAD_TEXELS + LIGHT_TEXELS * len(lights), 4), np.float32)
    if lighting is None:
        return rows
    view = np.asarray(view, np.float64)
    rows[0, :3], rows[0, 3] = lighting.ambient, len(lights)
    if lighting.eye is not None:
        rows[1, :3], rows[1, 3] = _point(view, lighting.eye), 1.0
    for i, light in enumerate(lights):
        r = rows[HEAD_TEXELS + LIGHT_TEXELS * i:][:LIGHT_TEXELS]
        shines = light.direction_array / np.linalg.norm(light.direction_array)
        r[0] = (KINDS[light.kind], light.strength if light.kind == "SUN" else light.power,
                np.cos(light.spot_size / 2.0), light.spot_blend)
        r[1, :3] = _point(view, light.position)
        r[2, :3] = view[:3, :3] @ shines
        r[3, :3] = light.color
    return rows


def _point(view: np.ndarray, p) -> np.ndarray:
    return view[:3, :3] @ np.asarray(p, np.float64) + view[:3, 3]
