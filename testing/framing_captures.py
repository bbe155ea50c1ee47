"""Generated captures for the framing tests and bench (tests/cli/test_cli_framing_visible.py,
bench/framing_bench.py): a subject in a sparse, faint halo, and a shell photographed from
one side. Both in the 3DGS file frame (RDF: up is -y), pure functions of their arguments.
"""
from __future__ import annotations

import math

import numpy as np

from addon.core.splats import SplatSet

SUBJECT_HEIGHT = 2.0  # the haloed subject's, base included (file units)


def haloed_capture(subject: int = 40000, halo: int = 2600, seed: int = 0,
                   halo_size: float = 5.0) -> SplatSet:
    """A robot on a base (an upright ellipsoid shell, 0.7 x 1.6 x 0.5, on a flat disk of
    radius 0.6), of trained-looking opaque splats, inside a ball `halo_size` times the
    subject's height across holding `halo` faint splats (opacity 0.01-0.2, sizes up to 5x
    the subject's): what real captures carry round their subject, too faint and too sparse
    to show."""
    rng = np.random.default_rng(seed)
    body, base = subject * 4 // 5, subject - subject * 4 // 5
    s = SplatSet.allocate(subject + halo, 0)
    d = rng.normal(size=(body, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    centre_up = 0.2 + 0.8  # the body's centre stands on the base (up is the file's -y)
    s.positions[:body] = d * (0.35, 0.8, 0.25) + (0.0, -centre_up, 0.0)
    r, turn = 0.6 * np.sqrt(rng.uniform(size=base)), rng.uniform(0, 2 * math.pi, base)
    s.positions[body:subject] = np.stack([r * np.cos(turn), -rng.uniform(0.0, 0.2, base),
                                          r * np.sin(turn)], axis=1)
    s.scales[:subject] = np.exp(rng.normal(math.log(0.015), 0.4, (subject, 3)))
    s.opacities[:subject] = rng.uniform(0.6, 1.0, subject)
    s.sh_dc[:body] = (0.9, 0.2, -0.4)  # an orange body on a grey base
    s.sh_dc[body:subject] = (-0.3, -0.3, -0.3)
    radius = 0.5 * halo_size * SUBJECT_HEIGHT
    d = rng.normal(size=(halo, 3))
    d *= (radius * rng.uniform(size=(halo, 1)) ** (1 / 3)) / np.linalg.norm(d, axis=1, keepdims=True)
    s.positions[subject:] = d + (0.0, -0.5 * SUBJECT_HEIGHT, 0.0)
    s.scales[subject:] = np.exp(rng.uniform(math.log(0.01), math.log(0.075), (halo, 3)))
    s.opacities[subject:] = rng.uniform(0.01, 0.2, halo)
    s.sh_dc[subject:] = rng.normal(0.0, 0.3, (halo, 3))
    q = rng.normal(size=(len(s.rotations), 4))
    s.rotations[:] = q / np.linalg.norm(q, axis=1, keepdims=True)
    return s


def one_sided_shell(n: int = 20000, facing_deg: float = 0.0, seed: int = 0,
                    depth: float = 1.0) -> SplatSet:
    """A hemisphere shell of flat splats lying on it (each one's thin axis along the shell's
    normal), open at the back: what a capture photographed from one side keeps. It faces
    the level direction `facing_deg` counter-clockwise (seen from above, in Blender's frame
    once imported) from the file's back (-z: the side 3DGS's reference camera stands on).
    depth: the shell's depth along its axis over its radius (below 1: flatter)."""
    rng = np.random.default_rng(seed)
    s = SplatSet.allocate(n, 0)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d[:, 2] = -np.abs(d[:, 2])  # the half towards the file's -z
    normal = d * (1.0, 1.0, 1.0 / depth)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    pos = d * (1.0, 1.0, depth)
    turn = math.radians(facing_deg)  # about the file's up (-y): counter-clockwise seen from above
    c, t = math.cos(turn), math.sin(turn)
    spin = np.array([[c, 0.0, -t], [0.0, 1.0, 0.0], [t, 0.0, c]])
    s.positions[:] = pos @ spin.T
    normal = normal @ spin.T
    s.scales[:] = (0.03, 0.03, 0.003)  # flat: thin along the splat's own z
    s.rotations[:] = _quaternion_taking_z_to(normal)
    s.opacities[:] = rng.uniform(0.5, 1.0, n)
    s.sh_dc[:] = 0.5
    return s


def _quaternion_taking_z_to(normals) -> np.ndarray:
    """(N, 4) w, x, y, z quaternions turning +z onto each unit normal (the shortest turn)."""
    w = 1.0 + normals[:, 2]
    q = np.stack([w, -normals[:, 1], normals[:, 0], np.zeros(len(normals))], axis=1)
    flipped = w < 1e-9  # the normal is -z: half a turn about x
    q[flipped] = (0.0, 1.0, 0.0, 0.0)
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def alpha_fill(alpha, threshold: float = 0.5) -> float:
    """The fill the framing promises, measured on a frame's alpha (H, W) in 0-1: the
    bounding rectangle of the pixels above `threshold`, its larger side over the frame's
    shorter side (0 for an empty frame)."""
    rows, cols = np.nonzero(np.asarray(alpha) > threshold)
    if not len(rows):
        return 0.0
    return max(np.ptp(rows) + 1, np.ptp(cols) + 1) / min(np.shape(alpha))
