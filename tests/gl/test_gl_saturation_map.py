"""The saturation map (shaders/gl_saturation_map.comp) pinned to numpy: a pyramid of
bitmaps, 32 cells to a uint, level 0 one bit per 4x4-pixel cell set where all its pixels
have T < 1e-4, level k the AND of 2x2 cells of level k - 1, cells past the tile's edge
counting as saturated. The draw stage culls and trims splats with it, so a wrong bit
either leaks light or wastes work; the early-termination tests see it only through a
frame."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.render_constants import T_STOP
from addon.gl import OffscreenRenderer


def expected_levels(alpha: np.ndarray, count: int) -> list[np.ndarray]:
    """(rows, cols) bool per level, from an (h, w) alpha image."""
    h, w = alpha.shape
    saturated = np.ones((-(-h // 4) * 4, -(-w // 4) * 4), bool)  # padding counts as saturated
    saturated[:h, :w] = alpha > np.float32(1.0) - np.float32(T_STOP)  # the shader's float32 test
    level = saturated.reshape(saturated.shape[0] // 4, 4, -1, 4).all(axis=(1, 3))
    out = [level]
    for _ in range(count - 1):
        rows, cols = level.shape
        padded = np.ones((rows + rows % 2, cols + cols % 2), bool)
        padded[:rows, :cols] = level
        level = padded.reshape(padded.shape[0] // 2, 2, -1, 2).all(axis=(1, 3))
        out.append(level)
    return out


def decoded_levels(raw: bytes, levels, w: int) -> list[np.ndarray]:
    words = np.frombuffer(raw, np.uint32)
    out = []
    for k, (offset, per_row, rows) in enumerate(levels):
        block = words[offset:offset + per_row * rows].reshape(rows, per_row)
        bits = np.unpackbits(block.astype("<u4").view(np.uint8), axis=1, bitorder="little")
        out.append(bits[:, :-(-w // (4 << k))].astype(bool))
    return out


@pytest.mark.parametrize("size", [(150, 70), (256, 128), (37, 9)])
def test_saturation_map_matches_numpy(size):
    w, h = size
    rng = np.random.default_rng(w)
    # mostly saturated blobs with open holes, so every level has both kinds of cell
    alpha = np.where(rng.random((h, w)) < 0.004, 0.5, 1.0 - 1e-5).astype(np.float32)
    alpha[h // 3: h // 3 + 5, w // 2: w // 2 + 20] = 0.9999  # T = 1e-4: not below the stop
    rgba = np.zeros((h, w, 4), np.float32)
    rgba[..., 3] = alpha
    with OffscreenRenderer() as r:
        c = r._state.compositor
        if c.sat_map is None:
            pytest.skip("no compute shaders: the GL 3.3 path has no saturation map")

        def build():
            t = c._targets(w, h)
            t["colour"].write(rgba.tobytes())
            c._build_map(t, w, h)
            return t["levels"], t["flags"].read()
        levels, raw = r._worker.call(build)
    got = decoded_levels(raw, levels, w)
    want = expected_levels(alpha, len(levels))
    assert 0 < want[0].mean() < 1 and want[1].any()
    for k, (g, e) in enumerate(zip(got, want)):
        np.testing.assert_array_equal(g, e, err_msg=f"level {k}")
    # and past each row's last cell, the spare bits read as saturated
    words = np.frombuffer(raw, np.uint32)
    for k, (offset, per_row, rows) in enumerate(levels):
        cols = -(-w // (4 << k))
        if cols % 32:
            last = words[offset + per_row - 1:offset + per_row * rows:per_row]
            assert (last >> np.uint32(cols % 32) == np.uint32(0xFFFFFFFF) >> np.uint32(cols % 32)).all()
