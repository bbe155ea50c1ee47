"""Dynamic captures through their readers: the fast path against the float64 reference and
against the raw formulas, at segment ends and at Delta = 0; stable indices and rest centres."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.dynamic import read_dynamic, reference_at
from addon.core.sh import C0
from testing.dynamic_captures import (LINEAR, SEGMENT_TIMES, raw_reference, raw_spacetime, same_rotation,
                                      write_raw_ply)
from testing.dynamic_checks import check_against_reference


@pytest.fixture
def spacetime_ply(tmp_path):
    rec = raw_spacetime(4000, seed=1)
    path = tmp_path / "seg.ply"
    write_raw_ply(path, rec)
    return path, rec


@pytest.mark.parametrize("t", SEGMENT_TIMES + (-0.3, 1.7))
def test_spacetime_fast_path_matches_reference(spacetime_ply, t):
    capture = read_dynamic(spacetime_ply[0])
    assert (capture.model, capture.unit, capture.t_start, capture.t_end) == ("spacetime", "segment", 0.0, 1.0)
    frame, _ = check_against_reference(capture, t)
    assert 0 < frame.alive < capture.count  # the times cut some splats, keep others


@pytest.mark.parametrize("t", SEGMENT_TIMES)
def test_spacetime_read_matches_raw_formulas(spacetime_ply, t):
    path, rec = spacetime_ply
    frame = read_dynamic(path).at(t)
    raw = raw_reference(rec, t)
    i = frame.index
    np.testing.assert_allclose(frame.splats.positions, raw["centre"][i], rtol=1e-5, atol=1e-5)
    assert same_rotation(frame.splats.rotations.astype(np.float64), raw["rotation"][i]).max() < 1e-5
    np.testing.assert_allclose(frame.splats.opacities, raw["opacity"][i], rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(frame.splats.scales, raw["scale"][i], rtol=1e-6)
    # Spacetime's f_dc is RGB: the SH DC renders it back (0.5 + C0 dc)
    rgb = np.stack([rec[f"f_dc_{c}"] for c in range(3)], 1)[i]
    np.testing.assert_allclose(0.5 + C0 * frame.splats.sh_dc, rgb, atol=2e-6)
    differ = np.setxor1d(i, np.flatnonzero(raw["opacity"] >= 1 / 255))
    assert np.all(np.abs(raw["opacity"][differ] - 1 / 255) < 1e-7)


def test_delta_zero_gives_the_stored_pose(tmp_path):
    rec = raw_spacetime(50, seed=2)
    rec["trbf_center"] = 0.5
    rec["opacity"] = 5.0
    write_raw_ply(tmp_path / "a.ply", rec)
    capture = read_dynamic(tmp_path / "a.ply")
    frame = capture.at(0.5)
    assert frame.alive == 50
    np.testing.assert_array_equal(frame.splats.positions, capture.rest_positions)
    np.testing.assert_allclose(frame.splats.opacities, 1 / (1 + np.exp(-5.0)), rtol=1e-6)


def test_indices_are_stable_and_rest_centres_follow_them(spacetime_ply):
    capture = read_dynamic(spacetime_ply[0])
    for t in (0.1, 0.6, 0.9):
        frame = capture.at(t)
        rest = capture.rest_positions[frame.index]
        # each kept splat's centre minus its motion at t is its rest centre
        delta = (t - capture.t_center[frame.index]).astype(np.float64)[:, None]
        m = capture.motion[frame.index].astype(np.float64)
        back = frame.splats.positions - (m[:, 0] * delta + m[:, 1] * delta ** 2 + m[:, 2] * delta ** 3)
        np.testing.assert_allclose(back, rest, atol=1e-5)
        np.testing.assert_array_equal(frame.index, np.flatnonzero(capture.alive_mask(t)))
    assert capture.rest().count == capture.count


def test_every_kept_splat_everywhere_is_a_view_of_read_only_data(tmp_path):
    rec = raw_spacetime(100, seed=3)
    rec["trbf_scale"] = 30.0  # never fades
    rec["opacity"] = 4.0
    write_raw_ply(tmp_path / "a.ply", rec)
    capture = read_dynamic(tmp_path / "a.ply")
    frame = capture.at(0.3)
    assert frame.alive == 100
    with pytest.raises(ValueError):
        frame.splats.scales[0, 0] = 1.0  # shared with the capture, so read-only
    assert frame.splats.positions.flags.writeable


@pytest.mark.parametrize("comment,unit,range_", [
    (("comment cfg_args: start=2.5 duration=4.0 fps=30 sh_degree=1",), "seconds", (2.5, 6.5)),
    ((), "segment", (0.0, 1.0)),
])
def test_linear_ply(tmp_path, comment, unit, range_):
    rec = raw_spacetime(3000, seed=4, names=LINEAR)
    rec["trbf_center"] = np.random.default_rng(5).uniform(*range_, 3000)
    write_raw_ply(tmp_path / "lin.ply", rec, comment)
    capture = read_dynamic(tmp_path / "lin.ply")
    assert (capture.model, capture.unit, (capture.t_start, capture.t_end)) == ("linear", unit, range_)
    assert capture.sh_degree == 1 and capture.omega is None
    if comment:
        assert (capture.fps, capture.duration, capture.start) == (30.0, 4.0, 2.5)
    for t in np.linspace(*range_, 5):
        frame, _ = check_against_reference(capture, t)
        raw = raw_reference(rec, t, rgb=False)
        np.testing.assert_allclose(frame.splats.positions, raw["centre"][frame.index], rtol=1e-5, atol=1e-5)
        np.testing.assert_allclose(frame.splats.sh_dc, raw["sh_dc"][frame.index], rtol=0, atol=0)
        np.testing.assert_array_equal(frame.splats.sh_rest[:, 0, 1], rec["f_rest_3"][frame.index])


def test_segments_play_in_order(tmp_path):
    paths, recs = [], []
    for k in range(3):
        rec = raw_spacetime(500 + 100 * k, seed=10 + k)
        paths.append(tmp_path / f"seg{k}.ply")
        write_raw_ply(paths[-1], rec)
        recs.append(rec)
    capture = read_dynamic(paths)
    assert (capture.segments, capture.t_start, capture.t_end, capture.count) == (3, 0.0, 3.0, 1800)
    for t, k, local in ((0.0, 0, 0.0), (1.0, 1, 0.0), (1.75, 1, 0.75), (2.5, 2, 0.5), (3.0, 2, 1.0)):
        frame, _ = check_against_reference(capture, t)
        first = int(capture.segment_offsets[k])
        assert frame.index.min() >= first and frame.index.max() < capture.segment_offsets[k + 1]
        raw = raw_reference(recs[k], local)
        np.testing.assert_allclose(frame.splats.positions, raw["centre"][frame.index - first], rtol=1e-5, atol=1e-5)


def test_reference_is_float64_and_follows_its_formula(spacetime_ply):
    capture = read_dynamic(spacetime_ply[0])
    ref = reference_at(capture, 0.4)
    assert ref.positions.dtype == np.float64 and ref.opacities.dtype == np.float64
    i = ref.index
    delta = 0.4 - capture.t_center[i].astype(np.float64)
    expect = capture.opacities[i] * np.exp(-(delta / capture.t_scale[i].astype(np.float64)) ** 2)
    np.testing.assert_array_equal(ref.opacities, expect)
