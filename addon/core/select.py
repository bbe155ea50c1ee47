"""Import-time selection on a SplatSet: cap the SH degree, prune by opacity, keep the
most important splats. Pure functions, so the Blender importer and the CLI share them."""
from __future__ import annotations

import numpy as np

from .splats import SplatSet


def importance(splats: SplatSet) -> np.ndarray:
    """Opacity x ellipsoid volume (product of the three scales), float64 against overflow:
    what a splat contributes to the image, roughly, independent of the view."""
    volume = np.prod(splats.scales.astype(np.float64), axis=1)
    return splats.opacities.astype(np.float64) * volume


def prune_opacity(splats: SplatSet, min_opacity: float) -> SplatSet:
    if min_opacity is None or min_opacity <= 0:
        return splats
    return splats.subset(splats.opacities >= min_opacity)


def limit_count(splats: SplatSet, max_count: int) -> SplatSet:
    """Keep the max_count most important splats, in their original order."""
    if max_count is None or max_count < 0 or splats.count <= max_count:
        return splats
    if max_count == 0:
        return splats.subset(np.zeros(splats.count, bool))
    score = importance(splats)
    keep = np.argpartition(-score, max_count - 1)[:max_count]
    return splats.subset(np.sort(keep))


def select(splats: SplatSet, sh_degree=None, min_opacity=None, max_count=None) -> SplatSet:
    """All three options in the order that does the least work."""
    splats = prune_opacity(splats, min_opacity)
    splats = limit_count(splats, max_count)
    if sh_degree is not None and sh_degree < splats.sh_degree:
        splats = splats.with_sh_degree(sh_degree)
    return splats
