"""Compressed PLY writer: reads back through our reader within each field's quantization step
(half a step, from the chunk bounds the file itself holds), and `.compressed.ply` is packed."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.formats import detect_format, read, write
from addon.core.formats.compressed_ply_write import _morton_order
from addon.core.formats.plyheader import read_elements
from addon.core.sh import C0


def _half_steps(path, n, names, bits):
    chunks = read_elements(path)[1]["chunk"]
    owner = np.arange(n) // 256
    lo = np.stack([chunks[f"min_{a}"] for a in names], 1)[owner].astype(np.float64)
    hi = np.stack([chunks[f"max_{a}"] for a in names], 1)[owner].astype(np.float64)
    return (hi - lo) / (2 * (np.array([(1 << b) - 1 for b in bits])))


@pytest.mark.parametrize("name", ["guitar.ply", "test64.ply"])
def test_round_trip_within_half_a_step(testdata, tmp_path, name):
    src = read(testdata / name)
    out = tmp_path / "o.compressed.ply"
    write(out, src)
    assert detect_format(out) == "compressed_ply"
    back = read(out)
    ref = src.subset(_morton_order(src.positions.astype(np.float64)))
    n, eps = src.count, 1e-6
    pos_step = _half_steps(out, n, "xyz", (11, 10, 11))
    assert (np.abs(back.positions - ref.positions) <= pos_step * (1 + eps) + 1e-6).all()
    scale_step = _half_steps(out, n, ("scale_x", "scale_y", "scale_z"), (11, 10, 11))
    assert (np.abs(np.log(back.scales / ref.scales)) <= scale_step * (1 + eps) + 1e-5).all()
    col_step = _half_steps(out, n, "rgb", (8, 8, 8)) / C0
    assert (np.abs(back.sh_dc - ref.sh_dc) <= col_step * (1 + eps) + 1e-5).all()
    assert np.abs(back.opacities - ref.opacities).max() <= 0.5 / 255 + 1e-6
    dot = np.abs(np.einsum("ij,ij->i", back.rotations, ref.rotations))
    assert dot.min() >= np.cos(2 * np.sqrt(3) * 0.5 / 1023 * np.sqrt(2))  # three 10-bit components
    assert back.sh_degree == src.sh_degree
    inside = np.abs(ref.sh_rest) < 4
    assert (np.abs(back.sh_rest - ref.sh_rest)[inside] <= 0.5 / 32 + 1e-6).all()
