"""Synthetic splat sets and INRIA PLY variants, for tests and benchmarks.

`write_ply_variant` writes the same splats with any property order, type, byte
order or ascii body, with or without normals and extra properties, so the
reader's tolerance of real-world layouts can be tested without shipping files.
"""
from __future__ import annotations

import numpy as np

from addon.core.splats import SplatSet
from addon.core.formats.ply import encode_vertices


def random_splats(n: int, degree: int = 3, seed: int = 0, *, centre=(0.0, 0.0, 0.0),
                  spread: float = 2.0, box: bool = False, log_scale=(-6.0, -1.0), opacity=None,
                  dc: float = 1.0, rest: float = 0.1) -> SplatSet:
    """Random splats, a pure function of the arguments: the one generator of the tests and
    benches. The defaults are capture-like: positions in a few metres, small scales.

    spread: the centres' standard deviation about `centre` (box: the half-width of a
    uniform box instead). log_scale: (low, high) draws log scales uniformly in that range;
    a number draws them normally about it (sd 0.5). opacity: (low, high) draws them
    uniformly; None as a logistic of N(0, 2) (most near 0 or 1, as trained captures have
    them). dc, rest: standard deviations of the SH DC and of the higher coefficients."""
    rng = np.random.default_rng(seed)
    s = SplatSet.allocate(n, degree)
    positions = rng.uniform(-spread, spread, (n, 3)) if box else rng.normal(0.0, spread, (n, 3))
    s.positions[:] = positions + np.asarray(centre, np.float64)
    if np.ndim(log_scale):
        s.scales[:] = np.exp(rng.uniform(log_scale[0], log_scale[1], (n, 3)))
    else:
        s.scales[:] = np.exp(rng.normal(log_scale, 0.5, (n, 3)))
    q = rng.normal(size=(n, 4))
    s.rotations[:] = q / np.linalg.norm(q, axis=1, keepdims=True)
    if opacity is None:
        s.opacities[:] = 1.0 / (1.0 + np.exp(-rng.normal(0.0, 2.0, n)))
    else:
        s.opacities[:] = rng.uniform(opacity[0], opacity[1], n)
    s.sh_dc[:] = rng.normal(0.0, dc, (n, 3))
    s.sh_rest[:] = rng.normal(0.0, rest, s.sh_rest.shape)
    return s


def shell_splats(n: int, degree: int = 3, seed: int = 0, *, radius: float = 1.0,
                 thickness: float = 0.02, size: float = 0.012) -> SplatSet:
    """random_splats on a noisy sphere shell about the origin: `radius`, relative radial
    noise `thickness` (sd), log scales about log(size * radius), and a DC colour that
    follows the direction (so the shell is not grey noise from every side)."""
    s = random_splats(n, degree, seed, spread=1.0, log_scale=float(np.log(size * radius)),
                      dc=0.3, rest=0.15)
    d = s.positions.astype(np.float64)  # isotropic normal draws: uniform directions
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    noise = np.random.default_rng((seed, 1)).normal(0.0, thickness, (n, 1))
    s.positions[:] = d * radius * (1.0 + noise)
    s.sh_dc[:] += 0.8 * d
    return s


def write_ply_variant(path, splats: SplatSet, encoding: str = "<", prop_type: str = "float",
                      order=None, normals: bool = True, extra=()) -> np.ndarray:
    """Write INRIA records as a PLY with the given layout; returns the raw records written.

    encoding: "<", ">" or "ascii"; prop_type: "float", "double" or "uchar" (uchar stores
    the raw values rounded and clipped to 0..255); order: property names in file order
    (default: standard); extra: names of unknown float properties to add (filled with 7).
    """
    base = encode_vertices(splats)
    names = list(order) if order is not None else list(base.dtype.names)
    if not normals:
        names = [n for n in names if n not in ("nx", "ny", "nz")]
    names += list(extra)
    code = {"float": "f4", "double": "f8", "uchar": "u1"}[prop_type]
    byte_order = ">" if encoding == ">" else "<"
    rec = np.zeros(splats.count, [(n, byte_order + code) for n in names])
    for n in names:
        values = base[n] if n in base.dtype.names else np.full(splats.count, 7.0)
        rec[n] = np.clip(np.round(values), 0, 255) if code == "u1" else values
    fmt = {"<": "binary_little_endian", ">": "binary_big_endian", "ascii": "ascii"}[encoding]
    header = ["ply", f"format {fmt} 1.0", f"element vertex {splats.count}"]
    header += [f"property {prop_type} {n}" for n in names] + ["end_header", ""]
    with open(path, "wb") as f:
        f.write("\n".join(header).encode("ascii"))
        if encoding == "ascii":
            # 9 digits round-trip float32, 17 round-trip float64
            text_format = {"u1": "%d", "f4": "%.9g", "f8": "%.17g"}[code]
            np.savetxt(f, rec.view((rec.dtype[0], len(names))) if len(names) else rec, fmt=text_format)
        else:
            rec.tofile(f)
    return rec
