"""Far outlier splats: the few that sit far outside a capture, found once per data version so
Blender 5.3's own engines can be spared them (issue 45).

Why: EEVEE stores splat centres quantised against the whole cloud's bounds (22 bits an axis,
in Blender's source), so a handful of stray splats far away coarsens every centre of the
capture: four faint splats at 1,000x guitar's size cost its covered pixels tens of dB
(bench/eevee_outliers_bench.py). Splatline's own renderers keep float32 centres and are not
affected, so this only decides what is handed to Blender's engines.

The rule. The capture's robust box is the per-axis 2-98 percentile box of the centres
(core/framing.robust_bounds, the framing's own); its radius r is half its diagonal. A splat
is a far outlier when its centre lies further than REACH x r from the box's middle. REACH = 8
keeps the handed-off bounds within 16 radii (8 of the box's diagonals): at 10x the measured
loss is at EEVEE's own noise level. They are left out only when they are few, at most MOST of
the splats: a capture whose far splats are many (an outdoor capture's sky) is not thinned,
and says so.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .framing import robust_bounds

REACH = 8.0     # x the robust radius
MOST = 1e-3     # the largest share of the splats ever left out


@dataclass(frozen=True)
class FarOutliers:
    """kept: indices of the splats to keep, ascending (None: keep them all), of `count`
    splats. far: how many lie beyond the reach; dropped: how many are left out (0 when they
    were too many)."""
    kept: np.ndarray | None
    count: int
    far: int
    dropped: int
    reach: float      # the distance beyond which a splat is far, in the data's units


def find(positions, reach: float = REACH, most: float = MOST) -> FarOutliers:
    """The far outliers of (N, 3) centres. Non-finite centres count as far."""
    pts = np.asarray(positions)
    count = len(pts)
    if count == 0:
        return FarOutliers(None, count, 0, 0, 0.0)
    try:
        bounds = robust_bounds(pts)
    except ValueError:  # no finite centre: nothing to measure against
        return FarOutliers(None, count, 0, 0, 0.0)
    limit = reach * bounds.radius
    offset = pts.astype(np.float64) - bounds.centre
    distance2 = np.einsum("ij,ij->i", offset, offset)
    near = distance2 <= limit * limit   # NaN compares False: far
    far = count - int(np.count_nonzero(near))
    if far == 0 or far > most * count:
        return FarOutliers(None, count, far, 0, limit)
    return FarOutliers(np.flatnonzero(near), count, far, far, limit)
