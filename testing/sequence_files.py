"""Splat sequences on disk: a folder of frame_NNNN.ply files."""
from __future__ import annotations

from addon.core.formats import write
from testing.synth import random_splats

N_FRAMES = 5


def write_frames(directory, count=N_FRAMES, n=40, degree=1, first=1):
    """Frames that differ everywhere (each frame its own random set) as frame_NNNN.ply."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for i in range(count):
        path = directory / f"frame_{first + i:04d}.ply"
        write(path, random_splats(n, degree=degree, seed=100 + i))
        paths.append(path)
    return paths
