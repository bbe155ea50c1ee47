"""Fold a RenderItem's per-object look into plain splat data, for export and bake.

The item's splats already carry the effect stack and the crop (as per-splat opacity), so
they are written as they are. On top of them, what is folded (exactly, before the
renderer's clamps):
- splat_scale    -> scales * splat_scale
- opacity_scale  -> opacities * opacity_scale, clipped to [0, 1] (a file cannot hold an
                    opacity above 1; the renderer's alpha cap 0.99 makes the difference
                    visible only for o * falloff between 0.99 / scale and 0.99)
- color_matrix   -> SH coefficients (see fold_color_matrix): exact, since the matrix is
                    affine and applied before the clamp at 0
- sh_degree cap  -> bands above the effective degree are dropped
What is not: the world matrix. Data stays in the object's own (file) frame, so a
re-import with the same axis convention and transform places it where it was.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .scene import IDENTITY_COLOR, RenderItem
from .sh import C0
from .splats import SplatSet


def fold_color_matrix(sh_dc: np.ndarray, sh_rest: np.ndarray, color_matrix: np.ndarray):
    """SH coefficients whose colour equals color_matrix applied to the original colour.

    colour = C0*dc + sum_k B_k*rest_k + 0.5 and the look maps it to M colour + b, so
    dc' = (M (C0 dc + 0.5) + b - 0.5) / C0 and rest'_k = M rest_k (computed in float64).
    """
    m = np.asarray(color_matrix, np.float64)
    lin, off = m[:, :3], m[:, 3]
    dc = np.asarray(sh_dc, np.float64)
    new_dc = ((C0 * dc + 0.5) @ lin.T + off - 0.5) / C0
    new_rest = np.asarray(sh_rest, np.float64) @ lin.T
    return new_dc.astype(np.float32), new_rest.astype(np.float32)


def baked_splats(item: RenderItem) -> SplatSet:
    """The splats a renderer would draw for item, in the object's frame, look folded in."""
    splats = item.splats.with_sh_degree(item.effective_sh_degree)
    scales = splats.scales
    if item.splat_scale != 1.0:
        scales = (scales.astype(np.float64) * item.splat_scale).astype(np.float32)
    opacities = splats.opacities
    if item.opacity_scale != 1.0:
        opacities = np.clip(opacities.astype(np.float64) * item.opacity_scale, 0.0, 1.0).astype(np.float32)
    sh_dc, sh_rest = splats.sh_dc, splats.sh_rest
    if not np.array_equal(item.color_matrix, IDENTITY_COLOR):
        sh_dc, sh_rest = fold_color_matrix(sh_dc, sh_rest, item.color_matrix)
    return replace(splats, scales=scales, opacities=opacities, sh_dc=sh_dc, sh_rest=sh_rest).check()
