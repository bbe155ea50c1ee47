"""Rotations that carry a file's axis convention into Blender's right-forward-up frame.

The convention goes on the object's transform, never into the data, so a round
trip is exact and the user can undo the rotation.
"""
from __future__ import annotations

import math

import numpy as np

from .splats import AXES_RDF, AXES_RFU, AXES_RUB

# Euler XYZ (radians) for the object's rotation.
_EULER = {
    AXES_RDF: (-math.pi / 2, 0.0, 0.0),  # file -y (up) -> +z, file +z (forward) -> +y
    AXES_RUB: (math.pi / 2, 0.0, 0.0),   # file +y (up) -> +z, file -z (forward) -> +y
    AXES_RFU: (0.0, 0.0, 0.0),
}


def euler_for(axes: str) -> tuple[float, float, float]:
    return _EULER[axes]


def matrix_for(axes: str) -> np.ndarray:
    """3x3 rotation taking file coordinates to Blender coordinates."""
    ax, _, _ = _EULER[axes]
    c, s = math.cos(ax), math.sin(ax)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]], np.float64).round(12)
