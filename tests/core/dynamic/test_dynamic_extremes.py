"""Stiff and extreme dynamic splats: finite results, drops counted, fast path = reference."""
from __future__ import annotations

import numpy as np

from addon.core.dynamic import read_dynamic, reference_at
from testing.dynamic_captures import raw_spacetime, write_raw_ply
from testing.dynamic_checks import check_against_reference


def _capture(tmp_path, rec):
    write_raw_ply(tmp_path / "x.ply", rec)
    return read_dynamic(tmp_path / "x.ply")


def test_zero_width_shows_only_at_its_centre(tmp_path):
    rec = raw_spacetime(4, seed=1)
    rec["trbf_scale"] = [-np.inf, -200.0, -np.inf, -200.0]  # exp underflows to 0 in float32
    rec["trbf_center"] = 0.5
    rec["opacity"] = 3.0
    capture = _capture(tmp_path, rec)
    assert capture.count == 4 and not capture.dropped
    np.testing.assert_array_equal(capture.at(0.5).index, [0, 1, 2, 3])  # Delta = 0: full opacity
    assert capture.at(0.5001).alive == 0
    for t in (0.5, 0.5001, 0.0):
        check_against_reference(capture, t)


def test_far_delta_with_cubic_motion_stays_finite(tmp_path):
    rec = raw_spacetime(3, seed=2)
    rec["trbf_scale"] = 60.0  # exp(60): never fades
    rec["opacity"] = 3.0
    rec["motion_6"] = [1e30, 1.0, 0.0]
    capture = _capture(tmp_path, rec)
    frame = capture.at(1e4)
    assert np.isfinite(frame.splats.positions).all() and np.isfinite(frame.splats.rotations).all()
    # splat 0's centre (1e42) overflows float32: left out and counted; the others are kept
    assert frame.overflow == 1 and list(frame.index) == [1, 2]
    ref = reference_at(capture, 1e4)
    np.testing.assert_allclose(frame.splats.positions, ref.positions[1:], rtol=1e-5)


def test_rotation_through_zero_drops_and_counts(tmp_path):
    rec = raw_spacetime(3, seed=3)
    for i, v in enumerate((1.0, 0.0, 0.0, 0.0)):
        rec[f"rot_{i}"] = v
        rec[f"omega_{i}"] = -v * 2.0  # rot + omega Delta = 0 at Delta = 0.5
    rec["omega_0"][2] = 0.0  # splat 2 never turns
    rec["trbf_center"] = 0.0
    rec["trbf_scale"] = 60.0
    rec["opacity"] = 3.0
    capture = _capture(tmp_path, rec)
    frame = capture.at(0.5)
    assert frame.zero_rotations == 2 and list(frame.index) == [2]
    assert reference_at(capture, 0.5).zero_rotations == 2
    assert capture.at(0.25).alive == 3 and capture.at(0.25).zero_rotations == 0


def test_tiny_and_huge_quaternions_normalise(tmp_path):
    rec = raw_spacetime(2, seed=4)
    rec["rot_0"] = [1e-30, 1e30]
    for name in ("rot_1", "rot_2", "rot_3", "omega_0", "omega_1", "omega_2", "omega_3"):
        rec[name] = 0.0
    rec["trbf_scale"], rec["opacity"] = 60.0, 3.0
    frame = _capture(tmp_path, rec).at(0.3)
    np.testing.assert_allclose(frame.splats.rotations, [[1, 0, 0, 0], [1, 0, 0, 0]])


def test_opacity_underflow_leaves_splats_out(tmp_path):
    rec = raw_spacetime(3, seed=5)
    rec["opacity"] = [-200.0, -np.inf, 3.0]  # sigmoid underflows to 0
    rec["trbf_scale"] = 60.0
    capture = _capture(tmp_path, rec)
    assert list(capture.at(0.5).index) == [2]
    check_against_reference(capture, 0.5)


def test_nan_in_any_time_field_is_dropped_and_counted(tmp_path):
    fields = ["trbf_center", "trbf_scale", "motion_4", "omega_2", "x", "opacity", "rot_1"]
    rec = raw_spacetime(len(fields) + 3, seed=6)
    for i, name in enumerate(fields):
        rec[name][i] = np.nan
    rec["motion_0"][len(fields)] = np.inf
    capture = _capture(tmp_path, rec)
    assert capture.count == 2
    assert capture.dropped == {"trbf_center": 1, "trbf_scale": 1, "motion": 2, "omega": 1, "position": 1,
                               "opacity": 1, "rotation": 1}
    for t in (0.0, 0.5, 1.0):
        frame, _ = check_against_reference(capture, t)
        assert np.isfinite(frame.splats.positions).all()


def test_never_turning_zero_rotation_is_dropped_at_read(tmp_path):
    rec = raw_spacetime(2, seed=7)
    for name in ("rot_0", "rot_1", "rot_2", "rot_3", "omega_0", "omega_1", "omega_2", "omega_3"):
        rec[name][0] = 0.0
    capture = _capture(tmp_path, rec)
    assert capture.count == 1 and capture.dropped == {"zero_rotation": 1}
