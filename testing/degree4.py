"""Degree-4 splats (SPZ 3+, Blender 5.3's own) and an INRIA PLY holding them, for the tests of
reading them to degree 3."""
from __future__ import annotations

import numpy as np

from addon.core.formats.ply import DC, POS, ROT, SCALE, rest_names
from addon.core.splats import SplatSet

N = 40


def degree4_splats(seed=0):
    """(degree-3 SplatSet, its band 4 (N, 9, 3))."""
    rng = np.random.default_rng(seed)
    s = SplatSet.allocate(N, 3)
    s.positions[:] = rng.normal(0, 1, (N, 3))
    s.scales[:] = np.exp(rng.normal(-3, 0.3, (N, 3)))
    q = rng.normal(size=(N, 4))
    s.rotations[:] = q / np.linalg.norm(q, axis=1, keepdims=True)
    s.opacities[:] = rng.uniform(0.1, 0.9, N)
    s.sh_dc[:] = rng.normal(0, 1, (N, 3))
    s.sh_rest[:] = rng.normal(0, 0.3, s.sh_rest.shape)
    return s, rng.normal(0, 0.3, (N, 9, 3)).astype(np.float32)


def write_ply4(path, s, band4):
    rest = np.concatenate([s.sh_rest, band4], 1)  # (N, 24, 3)
    names = list(POS) + list(DC) + rest_names(72) + ["opacity"] + list(SCALE) + list(ROT)
    rec = np.zeros(N, np.dtype([(n, "<f4") for n in names]))
    for i, name in enumerate(POS):
        rec[name] = s.positions[:, i]
    for i, name in enumerate(DC):
        rec[name] = s.sh_dc[:, i]
    for c in range(3):  # channel-major: f_rest_{c * 24 + k}
        for k in range(24):
            rec[f"f_rest_{c * 24 + k}"] = rest[:, k, c]
    rec["opacity"] = np.log(s.opacities / (1 - s.opacities))
    for i, name in enumerate(SCALE):
        rec[name] = np.log(s.scales[:, i])
    for i, name in enumerate(ROT):
        rec[name] = s.rotations[:, i]
    head = ["ply", "format binary_little_endian 1.0", f"element vertex {N}"]
    head += [f"property float {n}" for n in names] + ["end_header", ""]
    path.write_bytes("\n".join(head).encode() + rec.tobytes())
