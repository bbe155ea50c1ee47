"""Degree-4 files (SPZ 3+, Blender 5.3's own splats) read to degree 3, and the report says
what was dropped. No bpy."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from testing.spz_encode import encode
from addon.core.formats import read_with_report
from testing.degree4 import degree4_splats as _degree4, write_ply4 as _write_ply4

N = 40


def test_degree4_ply_keeps_bands_0_to_3_and_reports_band_4(tmp_path):
    s, band4 = _degree4()
    _write_ply4(tmp_path / "d4.ply", s, band4)
    got, report = read_with_report(tmp_path / "d4.ply")
    assert got.sh_degree == 3 and report.sh_degree_in_file == 4
    np.testing.assert_array_equal(got.sh_rest, s.sh_rest)  # the stride is 24, not 15
    np.testing.assert_allclose(got.opacities, s.opacities, rtol=1e-5)
    assert "SH degree 4" in report.dropped_sh and "15..23" in report.dropped_sh


def test_degree4_ply_capped_lower_still_says_the_file_degree(tmp_path):
    s, band4 = _degree4(1)
    _write_ply4(tmp_path / "d4.ply", s, band4)
    got, report = read_with_report(tmp_path / "d4.ply", sh_degree=1)
    assert got.sh_degree == 1 and report.sh_degree_in_file == 4
    np.testing.assert_array_equal(got.sh_rest, s.sh_rest[:, :3])


@pytest.mark.parametrize("version", [3, 4])
def test_degree4_spz_keeps_bands_0_to_3(tmp_path, version):
    s, band4 = _degree4(2)
    rest = np.concatenate([s.sh_rest, band4], 1)
    fake = SimpleNamespace(count=N, sh_degree=4, positions=s.positions, opacities=s.opacities,
                           sh_dc=s.sh_dc, scales=s.scales, rotations=s.rotations, sh_rest=rest)
    (tmp_path / "d4.spz").write_bytes(encode(fake, version))
    got, report = read_with_report(tmp_path / "d4.spz")
    assert got.sh_degree == 3 and report.sh_degree_in_file == 4 and report.dropped_sh
    np.testing.assert_allclose(got.sh_rest, s.sh_rest, atol=1.0 / 128 + 1e-6)  # 8-bit SH


def test_degree3_file_reports_nothing_dropped(testdata):
    _, report = read_with_report(testdata / "test64.ply")
    assert report.sh_degree_in_file == 3 and report.dropped_sh == ""
