"""Dynamic files: sniffing, round trips (PLY, .splatv), conversions, and bad input."""
from __future__ import annotations

import json

import numpy as np
import pytest

from addon.core.dynamic import (is_dynamic_file, read_dynamic, to_fourdgs, to_linear, to_spacetime,
                                write_dynamic)
from addon.core.dynamic.splatv import MAGIC
from addon.core.errors import SplatFormatError
from addon.core.formats import write
from addon.core.splats import SplatSet
from testing.dynamic_captures import LINEAR, raw_spacetime, write_raw_ply
from testing.dynamic_checks import check_against_reference


@pytest.fixture
def capture(tmp_path):
    write_raw_ply(tmp_path / "src.ply", raw_spacetime(1500, seed=21))
    return read_dynamic(tmp_path / "src.ply")


def _same_frames(a, b, times=(0.0, 0.3, 0.5, 1.0), atol=1e-6):
    for t in times:
        fa, fb = a.at(t), b.at(t)
        np.testing.assert_array_equal(fa.index, fb.index)
        np.testing.assert_allclose(fa.splats.positions, fb.splats.positions, atol=atol)
        np.testing.assert_allclose(fa.splats.opacities, fb.splats.opacities, rtol=1e-5, atol=1e-7)


def test_spacetime_ply_round_trip(tmp_path, capture):
    write_dynamic(tmp_path / "out.ply", capture)
    again = read_dynamic(tmp_path / "out.ply")
    for name in ("positions", "motion", "rotations", "omega", "t_center"):
        np.testing.assert_array_equal(getattr(again, name), getattr(capture, name))
    for name in ("scales", "opacities", "t_scale", "sh_dc"):
        np.testing.assert_allclose(getattr(again, name), getattr(capture, name), rtol=2e-7, atol=1e-7)
    _same_frames(capture, again)


def test_linear_ply_round_trip_keeps_cfg_args(tmp_path):
    rec = raw_spacetime(500, seed=22, names=LINEAR)
    write_raw_ply(tmp_path / "lin.ply", rec, ("comment cfg_args: start=1 duration=2 fps=25",))
    capture = read_dynamic(tmp_path / "lin.ply")
    write_dynamic(tmp_path / "again.ply", capture)
    again = read_dynamic(tmp_path / "again.ply")
    assert (again.unit, again.t_start, again.t_end, again.fps) == ("seconds", 1.0, 3.0, 25.0)
    np.testing.assert_array_equal(again.sh_rest, capture.sh_rest)
    _same_frames(capture, again, times=(1.0, 2.0, 3.0))


def test_splatv_round_trip_is_half_float_close(tmp_path, capture):
    write_dynamic(tmp_path / "a.splatv", capture)
    head = (tmp_path / "a.splatv").read_bytes()[:8]
    assert int.from_bytes(head[:4], "little") == MAGIC
    again = read_dynamic(tmp_path / "a.splatv")
    assert (again.model, again.count, again.source) == ("spacetime", capture.count, ".splatv")
    np.testing.assert_array_equal(again.positions, capture.positions)
    np.testing.assert_allclose(again.motion, capture.motion, rtol=1e-3, atol=1e-4)
    np.testing.assert_allclose(again.t_scale, capture.t_scale, rtol=1e-3)
    np.testing.assert_allclose(again.opacities, capture.opacities, atol=0.5 / 255 + 1e-7)
    for t in (0.0, 0.5, 1.0):
        check_against_reference(again, t)
    # written again, a read .splatv gives the same bytes
    write_dynamic(tmp_path / "b.splatv", again)
    assert (tmp_path / "b.splatv").read_bytes() == (tmp_path / "a.splatv").read_bytes()


def test_sniffing(tmp_path, capture):
    write_dynamic(tmp_path / "d.ply", capture)
    write_dynamic(tmp_path / "d.splatv", capture)
    (tmp_path / "d.4dgs").write_bytes(b"\x894DGS1\r\n" + bytes(32))
    write(tmp_path / "static.ply", SplatSet.allocate(3))
    (tmp_path / "junk.bin").write_bytes(b"hello")
    assert [is_dynamic_file(tmp_path / n) for n in ("d.ply", "d.splatv", "d.4dgs", "static.ply", "junk.bin",
                                                    "missing.ply")] == [True, True, True, False, False, False]
    with pytest.raises(SplatFormatError, match="4dgs"):
        read_dynamic(tmp_path / "d.4dgs")
    with pytest.raises(SplatFormatError, match="static PLY"):
        read_dynamic(tmp_path / "static.ply")


def _one_line(exc) -> str:
    text = str(exc.value)
    assert "\n" not in text
    return text


def test_bad_splatv_files(tmp_path, capture):
    write_dynamic(tmp_path / "ok.splatv", capture)
    data = (tmp_path / "ok.splatv").read_bytes()
    length = int.from_bytes(data[4:8], "little")
    cases = {
        "truncated": data[:len(data) // 2],
        "json_len": data[:4] + (1 << 30).to_bytes(4, "little") + data[8:],
        "not_json": data[:8] + b"{" * length + data[8 + length:],
        "odd_size": data[:8] + json.dumps([{"type": "splat", "size": 65}]).encode().ljust(length) + data[8 + length:],
    }
    for name, blob in cases.items():
        (tmp_path / f"{name}.splatv").write_bytes(blob)
        with pytest.raises(SplatFormatError) as exc:
            read_dynamic(tmp_path / f"{name}.splatv")
        assert f"{name}.splatv" in _one_line(exc)


def test_bad_dynamic_plys(tmp_path):
    rec = raw_spacetime(10, seed=23)
    write_raw_ply(tmp_path / "ok.ply", rec)
    data = (tmp_path / "ok.ply").read_bytes()
    (tmp_path / "short.ply").write_bytes(data[:-40])
    (tmp_path / "huge.ply").write_bytes(data.replace(b"element vertex 10", b"element vertex 999999999"))
    full = [(n, "<f4") for n in ("x", "y", "z", "trbf_center", "trbf_scale")] + \
        [(f"f_dc_{i}", "<f4") for i in range(9)] + [("f_t_0", "<f4")]
    write_raw_ply(tmp_path / "full.ply", np.zeros(2, full))
    partial = rec[[n for n in rec.dtype.names if n != "omega_3"]]
    write_raw_ply(tmp_path / "partial.ply", np.ascontiguousarray(partial))
    for name, words in (("short", "truncated"), ("huge", "truncated"), ("full", "'full'"), ("partial", "omega_3")):
        with pytest.raises(SplatFormatError, match=words) as exc:
            read_dynamic(tmp_path / f"{name}.ply")
        assert f"{name}.ply" in _one_line(exc)


def test_conversions(tmp_path, capture):
    with pytest.raises(SplatFormatError, match="cubic"):
        to_linear(capture)
    with pytest.raises(SplatFormatError, match="cubic"):
        to_fourdgs(capture, seconds_per_unit=2.0)
    linear = raw_spacetime(800, seed=24)
    for name in [f"motion_{i}" for i in range(3, 9)] + [f"omega_{i}" for i in range(4)]:
        linear[name] = 0.0
    write_raw_ply(tmp_path / "flat.ply", linear)
    flat = read_dynamic(tmp_path / "flat.ply")
    as_linear = to_linear(flat)
    assert as_linear.model == "linear" and as_linear.motion.shape == (800, 1, 3)
    _same_frames(flat, as_linear)
    _same_frames(flat, to_spacetime(as_linear))
    # to .4dgs's model: seconds, sigma = s / sqrt(2); the same curve, cut at 0.05
    fourd = to_fourdgs(flat, seconds_per_unit=2.0)
    assert (fourd.model, fourd.unit, fourd.t_end) == ("4dgs", "seconds", 2.0)
    for t in (0.0, 0.4, 0.9):
        a, b = flat.at(t), fourd.at(2.0 * t)
        common, ia, ib = np.intersect1d(a.index, b.index, return_indices=True)
        assert set(b.index) <= set(a.index) and common.size > 0.5 * a.alive
        np.testing.assert_allclose(a.splats.positions[ia], b.splats.positions[ib], atol=1e-5)
        np.testing.assert_allclose(a.splats.opacities[ia], b.splats.opacities[ib], rtol=1e-5)
        check_against_reference(fourd, 2.0 * t)
    with pytest.raises(SplatFormatError, match="cannot write"):
        write_dynamic(tmp_path / "x.spz", capture)


def test_the_bad_value_pass_takes_a_capture_of_no_splats():
    """drop_bad, which every reader runs, on 0 splats (reshape(0, -1) has no width)."""
    from addon.core.dynamic.ply_read import drop_bad, subset
    from testing.dynamic_scenes import spacetime_capture

    capture = spacetime_capture(4)
    assert drop_bad(subset(capture, np.zeros(capture.count, bool))).count == 0
