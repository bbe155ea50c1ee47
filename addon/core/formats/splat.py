"""antimatter15 .splat: no header, 32 bytes per splat, little endian:
  3 float32 position, 3 float32 linear scale,
  4 uint8 RGBA: colour = 0.5 + C0 * dc (so dc = (c/255 - 0.5) / C0), alpha = opacity * 255,
  4 uint8 rotation: q = (b - 128) / 128, w x y z (normalized after decoding).
Higher SH bands are not stored. Axis convention: RDF (as the INRIA file it came from).
Writers of this format usually reorder splats (by size x opacity), so compare as sets.
"""
from __future__ import annotations

import numpy as np

from ..errors import SplatFormatError
from ..sh import C0
from ..splats import AXES_RDF, SplatSet
from ._common import check_budget, normalize_quats_, write_file
from .readfile import OpenedFile

RECORD = np.dtype([("position", "<f4", 3), ("scale", "<f4", 3), ("rgba", "u1", 4), ("rot", "u1", 4)])
assert RECORD.itemsize == 32


def read_splat(path, max_degree: int = 3, max_splats=None) -> SplatSet:
    with OpenedFile(path) as f:
        if f.size % RECORD.itemsize:
            raise SplatFormatError(path, f"truncated or not a .splat: {f.size} bytes is not a multiple "
                                         f"of {RECORD.itemsize}")
        check_budget(path, f.size // RECORD.itemsize, 0, max_splats)
        rec = f.read_array(RECORD, f.size // RECORD.itemsize, 0)
        f.check_unchanged()
    n = rec.shape[0]
    rgba = rec["rgba"].astype(np.float32) / np.float32(255.0)
    s = SplatSet.allocate(0, 0, AXES_RDF)
    s.positions = np.ascontiguousarray(rec["position"])
    s.scales = np.ascontiguousarray(rec["scale"])
    s.sh_dc = (rgba[:, :3] - np.float32(0.5)) / np.float32(C0)
    s.opacities = np.ascontiguousarray(rgba[:, 3])
    s.rotations = normalize_quats_((rec["rot"].astype(np.float32) - 128.0) / np.float32(128.0))
    s.sh_rest = np.zeros((n, 0, 3), np.float32)
    return s


def _u8(x: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(x), 0, 255).astype(np.uint8)


def encode_splat(splats: SplatSet) -> np.ndarray:
    rec = np.zeros(splats.count, RECORD)
    rec["position"] = splats.positions
    rec["scale"] = splats.scales
    rec["rgba"][:, :3] = _u8((0.5 + C0 * splats.sh_dc.astype(np.float64)) * 255.0)
    rec["rgba"][:, 3] = _u8(splats.opacities.astype(np.float64) * 255.0)
    rec["rot"] = _u8(splats.rotations.astype(np.float64) * 128.0 + 128.0)
    return rec


def write_splat(path, splats: SplatSet) -> None:
    """Writes in the given order (no reordering), so a write/read round trip keeps indices."""
    splats.check()
    write_file(path, encode_splat(splats))
