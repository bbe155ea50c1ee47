"""Generated dynamic captures (no package ships samples) and their scenes in Blender."""
from __future__ import annotations

import numpy as np

from dataclasses import replace

from addon.core.dynamic.capture import DynamicCapture
from addon.core.dynamic.convert import to_fourdgs
from addon.core.sh import C0


def spacetime_capture(n: int = 3000, seed: int = 7, segments: int = 1) -> DynamicCapture:
    """A Spacetime-lite capture: a blob of splats in the PLY's frame (RDF) that drift with
    cubic motion, turn (omega) and fade in and out around their own time centres, each
    segment a blob of its own."""
    rng = np.random.default_rng(seed)
    count = n * segments
    f32 = np.float32
    positions = rng.normal(0.0, 0.35, (count, 3)).astype(f32)
    motion = np.zeros((count, 3, 3), f32)
    motion[:, 0] = rng.normal(0.0, 0.6, (count, 3))
    motion[:, 1] = rng.normal(0.0, 0.3, (count, 3))
    motion[:, 2] = rng.normal(0.0, 0.2, (count, 3))
    rotations = rng.normal(0.0, 1.0, (count, 4)).astype(f32)
    rotations /= np.linalg.norm(rotations, axis=1, keepdims=True)
    rgb = rng.uniform(0.15, 0.95, (count, 3))
    return DynamicCapture(
        model="spacetime", positions=positions, motion=motion, rotations=rotations,
        omega=rng.normal(0.0, 0.8, (count, 4)).astype(f32),
        scales=np.exp(rng.normal(-3.3, 0.3, (count, 3))).astype(f32),
        opacities=rng.uniform(0.5, 0.95, count).astype(f32),
        sh_dc=((rgb - 0.5) / C0).astype(f32), sh_rest=np.zeros((count, 0, 3), f32),
        t_center=rng.uniform(0.0, 1.0, count).astype(f32),  # each segment's own time
        t_scale=np.exp(rng.normal(-0.7, 0.2, count)).astype(f32),
        t_start=0.0, t_end=float(segments), unit="segment",
        segment_offsets=np.arange(segments + 1, dtype=np.int64) * n).check()


def linear_capture(n: int = 3000, seed: int = 7) -> DynamicCapture:
    """The same blob with linear motion only, in seconds over [0, 2] (a linear-motion PLY)."""
    c = spacetime_capture(n, seed)
    return replace(c, model="linear", motion=np.ascontiguousarray(c.motion[:, :1]), omega=None,
                   t_center=c.t_center * np.float32(2.0), t_scale=c.t_scale * np.float32(2.0),
                   t_end=2.0, unit="seconds", segment_offsets=None).check()


def fourdgs_capture(n: int = 3000, seed: int = 7) -> DynamicCapture:
    """The linear capture in .4dgs' model (seconds, Gaussian fade, cut-off)."""
    return to_fourdgs(linear_capture(n, seed)).check()


# representation -> (file name, generator): every kind Splatline reads
KINDS = {"spacetime": ("dancer.ply", spacetime_capture), "splatv": ("dancer.splatv", spacetime_capture),
         "linear": ("walker.ply", linear_capture), "4dgs": ("walker.4dgs", fourdgs_capture)}
