"""What evaluating a dynamic capture at one time gives (DynamicCapture.at)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..splats import SplatSet

ALPHA_MIN = 1.0 / 255.0  # opacity below which a splat at time t is left out


@dataclass
class Frame:
    """A capture evaluated at one time: what `DynamicCapture.at(t)` returns.

    splats          the kept splats (activated, float32, the capture's axes)
    index           (M,) int64: splats.positions[i] is capture splat index[i]; ascending
    zero_rotations  splats left out because their rotation at t is the zero quaternion
    overflow        splats left out because their centre at t overflows float32 (far Delta)
    """

    t: float
    splats: SplatSet
    index: np.ndarray
    zero_rotations: int = 0
    overflow: int = 0

    @property
    def alive(self) -> int:
        return int(self.index.shape[0])
