"""Import-time selection (SH cap, opacity prune, importance-ordered count limit) and the
.splat writer round trip."""
from __future__ import annotations

import numpy as np

from addon.core.formats import read, write
from testing.synth import random_splats
from addon.core.select import importance, limit_count, prune_opacity, select
from addon.core.sh import C0


def test_prune_opacity():
    s = random_splats(1000, 1, seed=1)
    kept = prune_opacity(s, 0.5)
    assert kept.count == int((s.opacities >= 0.5).sum()) and (kept.opacities >= 0.5).all()
    assert prune_opacity(s, None) is s and prune_opacity(s, 0.0) is s


def test_limit_count_keeps_most_important_in_order():
    s = random_splats(1000, 0, seed=2)
    score = importance(s)
    kept = limit_count(s, 100)
    assert kept.count == 100
    threshold = np.sort(score)[-100]
    assert (importance(kept) >= threshold).all()
    index = np.flatnonzero(score >= threshold)
    np.testing.assert_array_equal(kept.positions, s.positions[index])  # original order kept
    assert limit_count(s, 5000) is s and limit_count(s, 0).count == 0


def test_importance_is_opacity_times_volume():
    s = random_splats(3, 0, seed=3)
    s.scales[:] = [[1, 2, 3], [1, 1, 1], [0.5, 0.5, 0.5]]
    s.opacities[:] = [0.5, 1.0, 1.0]
    np.testing.assert_allclose(importance(s), [3.0, 1.0, 0.125])


def test_select_all_options(testdata):
    full = read(testdata / "test64.ply")
    s = read(testdata / "test64.ply", sh_degree=2, min_opacity=0.1, max_count=20)
    assert s.sh_degree == 2 and s.count == min(20, int((full.opacities >= 0.1).sum()))
    assert select(full, sh_degree=5).sh_degree == 3  # a cap never adds bands


def test_splat_write_read_round_trip(tmp_path, testdata):
    """Positions and scales are float32 in the file: exact. Colour and alpha are rounded to
    u8: within half a step (colour after clipping to [0, 1]). Rotation bytes are rounded to
    steps of 1/128: each component within 1/256, so |e| <= 1/128 and the renormalized
    quaternion within 2|e| = 1/64 per component (sign-aligned)."""
    src = read(testdata / "test64.ply")
    write(tmp_path / "t.splat", src)
    got = read(tmp_path / "t.splat")
    assert got.count == 64 and got.sh_degree == 0
    np.testing.assert_array_equal(got.positions, src.positions)
    np.testing.assert_array_equal(got.scales, src.scales)
    eps = 1e-6
    colour = np.clip(0.5 + C0 * src.sh_dc, 0, 1)
    assert np.abs(0.5 + C0 * got.sh_dc - colour).max() <= 0.5 / 255 + eps
    assert np.abs(got.opacities - src.opacities).max() <= 0.5 / 255 + eps
    sign = np.sign(np.einsum("ij,ij->i", got.rotations, src.rotations))[:, None]
    assert np.abs(got.rotations * sign - src.rotations).max() <= 1 / 64 + eps


def test_write_reexpresses_other_conventions(tmp_path, testdata):
    """An spz declared RUB (Niantic's convention) written to .ply lands in RDF: a half turn
    about x, so y and z flip and the Blender-frame positions are unchanged."""
    from addon.core.axes import matrix_for

    rub = read(testdata / "test64.spz", axes="RUB")
    write(tmp_path / "r.ply", rub)
    rdf = read(tmp_path / "r.ply")
    assert rdf.axes == "RDF"
    np.testing.assert_allclose(rdf.positions, rub.positions * [1, -1, -1], atol=1e-7)
    np.testing.assert_allclose(rdf.positions @ matrix_for("RDF").T, rub.positions @ matrix_for("RUB").T,
                               atol=1e-6)
