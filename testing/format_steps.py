"""How far a written SPZ or SOG may read back from the splats written: each format's
quantisation step (SPZ), or the codebook the file itself holds (SOG). One copy of the
bounds, for the format tests (test_formats_write_spz_sog.py) and the export tests
(test_native_export.py); never loosen one to make a test pass."""
from __future__ import annotations

import json
import zipfile

import numpy as np

from addon.core.formats.sog_write import log_transform, sog_order
from addon.core.quantize import nearest_1d

SPZ_ROTATION_HALF_STEP = 0.5 * np.sqrt(0.5) / 511  # smallest-three, 9 bits + sign
SOG_ROTATION_HALF_STEP = 1 / (255 * np.sqrt(2))  # smallest-three, 8 bits


def _rot_bound_dot(half_step):
    """Three stored components off by <= h each; the rebuilt largest one by <= 3h (it is
    the largest, so d|c|/d(stored) <= 1): |dq|^2 <= 12 h^2, dot >= 1 - 6 h^2."""
    return 1.0 - 6.0 * half_step ** 2 - 1e-6


def same_rotation(back, ref, half_step):
    dot = np.abs(np.einsum("ij,ij->i", back.astype(np.float64), ref.astype(np.float64)))
    assert dot.min() >= _rot_bound_dot(half_step)


def assert_spz_within_steps(back, src):
    """back (read from an .spz written from src) within SPZ's steps of src, splat by splat.
    The file holds RUB (SPZ's frame: the writer turns a set in another), so back is turned
    into src's frame first: a half or quarter turn about x moves no value off its step."""
    from addon.core.reframe import reframe

    back = reframe(back, src.axes)
    assert back.count == src.count and back.sh_degree == src.sh_degree
    tol32 = np.abs(src.positions) * 1.2e-7  # float32 rounding of the decoded value
    assert (np.abs(back.positions - src.positions) <= 0.5 / 4096 + tol32).all()
    assert np.abs(back.opacities - src.opacities).max() <= 0.5 / 255 + 1e-6
    dc = np.clip(src.sh_dc, -0.5 / 0.15, 0.5 / 0.15)  # the u8 colour range
    assert np.abs(back.sh_dc - dc).max() <= 0.5 / 255 / 0.15 + 1e-5
    log_s = np.clip(np.log(src.scales), -10, 255 / 16 - 10)
    assert np.abs(np.log(back.scales) - log_s).max() <= 0.5 / 16 + 1e-5
    same_rotation(back.rotations, src.rotations, SPZ_ROTATION_HALF_STEP)
    if src.sh_degree:  # rounding to 1/128, then snapping to buckets of 8 (band 1) / 16
        err = np.abs(back.sh_rest - np.clip(src.sh_rest, -1, 127 / 128)) * 128
        assert err[:, :3].max() <= 0.5 + 4 + 1e-3
        assert err[:, 3:].max() <= 0.5 + 8 + 1e-3


def sog_meta(path):
    with zipfile.ZipFile(path) as z:
        return json.loads(z.read("meta.json"))


def nearest_error(values, codebook):
    book = np.asarray(codebook, np.float32)
    return np.abs(book[nearest_1d(values.astype(np.float32), book).astype(np.int64)] - values)


def assert_sog_within_steps(back, src, meta):
    """back (read from a bundled .sog written from src, whose meta.json is `meta`) within
    SOG's steps of src, in the file's own splat order (sog_order). Returns src in that order."""
    ref = src.subset(sog_order(src.positions))
    assert back.count == src.count and back.sh_degree == src.sh_degree and meta["count"] == src.count
    span = np.array(meta["means"]["maxs"]) - np.array(meta["means"]["mins"])
    t_err = np.abs(log_transform(back.positions.astype(np.float64)) - log_transform(ref.positions.astype(np.float64)))
    assert (t_err <= span / 65535 / 2 * (1 + 1e-6) + 1e-6).all()
    # codebook columns: each value decodes to the codebook entry nearest to it
    log_err = np.abs(np.log(back.scales) - np.log(ref.scales))
    assert (log_err <= nearest_error(np.log(ref.scales), meta["scales"]["codebook"]) + 1e-5).all()
    assert (np.abs(back.sh_dc - ref.sh_dc) <= nearest_error(ref.sh_dc, meta["sh0"]["codebook"]) + 1e-6).all()
    visible = ref.opacities >= 0.5 / 255
    assert np.abs(back.opacities - ref.opacities)[visible].max() <= 0.5 / 255 + 1e-6
    assert (back.opacities[~visible] == np.float32(1 / 255)).all()  # alpha kept >= 1
    same_rotation(back.rotations, ref.rotations, SOG_ROTATION_HALF_STEP)
    if src.sh_degree:
        bound = nearest_error(ref.sh_rest, meta["shN"]["codebook"])
        assert (np.abs(back.sh_rest - ref.sh_rest) <= bound + 1e-6).all()
    return ref
