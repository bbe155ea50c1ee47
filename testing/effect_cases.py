"""Effect parameters that meet every branch of the colour kernels (reveal, grade) with a
real gizmo frame: shared by the tests that pin a second implementation to the kernels."""
from __future__ import annotations

import itertools

import numpy as np

from addon.core.effects import Grade, Reveal


def gizmo() -> np.ndarray:
    """A turned, scaled, moved gizmo frame, as an Empty parented in a scene gives."""
    c, s = np.cos(0.4), np.sin(0.4)
    m = np.array([[c, -s, 0, 0.3], [s, c, 0, -1.2], [0, 0, 1, 0.2], [0, 0, 0, 1]], float)
    m[:3, :3] = m[:3, :3] @ np.diag([0.7, 0.7, 1.3])
    return m


FRAMES = (np.eye(4), gizmo())


def varied(main, others):
    """Every combination of the `main` settings, each with the next combination of the
    `others` in turn, so every value of every setting is met without the full product."""
    rest = list(itertools.product(*others))
    for i, first in enumerate(itertools.product(*main)):
        yield first + rest[(i * 7) % len(rest)]


def reveals():
    colours = ((1.0, 0.45, 0.1), (-1.0, -0.5, -0.0), (1.0, -0.2, 0.0))  # +0 / -0 / mixed glow
    for shape, width, invert, shrink, progress, glow, amount, frame, colour in varied(
            (("PLANE", "SPHERE", "NOISE"), (0.0, 0.05, 0.8), (False, True), (0.0, 0.7)),
            ((-0.5, 0.0, 0.6), (0.0, 1.5), (0.4, 1.0), FRAMES, colours)):
        yield Reveal(shape=shape, progress=progress, width=width, invert=invert, shrink=shrink,
                     glow_strength=glow, glow_color=colour, amount=amount,
                     frequency=3.0, seed=2, frame=frame)


def grades():
    stops = (((0.0, (0.1, 0.2, 1.0)), (1.0, (1.0, 0.4, 0.1))),
             ((1.0, (1.0, 0.4, 1.0)), (0.0, (0.1, 0.4, 1.0)), (0.3, (0.5, 0.5, 0.5))),
             ((0.2, (0.0, 0.0, 0.0)), (0.2, (1.0, 1.0, 1.0))),
             ((0.25, (0.3, 0.1, 0.0)), (0.75, (0.0, 0.9, 0.2))))
    for field, mode, stop, (low, high), amount, frame in varied(
            (("HEIGHT", "DISTANCE", "NOISE"), ("MIX", "MULTIPLY", "ADD"), stops),
            (((-1.0, 1.5), (0.5, 0.5), (2.0, -1.0)), (0.3, 1.0), FRAMES)):
        yield Grade(field=field, mode=mode, stops=stop, low=low, high=high, amount=amount,
                    frequency=2.5, seed=4, frame=frame)
