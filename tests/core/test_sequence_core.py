"""core/sequence.py and core/fold_look.py: no bpy."""
from __future__ import annotations

import threading

import numpy as np
import pytest

from addon.core import sequence as seq
from addon.core.fold_look import baked_splats, fold_color_matrix
from addon.core.errors import SplatFormatError
from addon.core.formats import read, write
from testing.synth import random_splats
from addon.core.scene import RenderItem
from addon.core.sh import C0, sh_basis


def _touch(directory, names):
    for name in names:
        (directory / name).write_bytes(b"x")


# ---- time -> frame mapping -------------------------------------------------------------

@pytest.mark.parametrize("time,expected", [(1, 0), (2, 1), (5, 4), (6, 4), (100, 4), (0, 0), (-7, 0),
                                           (3.99, 2), (1.5, 0)])
def test_hold_clamps_and_floors(time, expected):
    assert seq.frame_index(time, 5, start=1, mode=seq.HOLD) == expected


@pytest.mark.parametrize("time,expected", [(1, 0), (5, 4), (6, 0), (7, 1), (0, 4), (-1, 3), (-4, 0),
                                           (11, 0), (6.5, 0)])
def test_loop_wraps_both_ways(time, expected):
    assert seq.frame_index(time, 5, start=1, mode=seq.LOOP) == expected


def test_ping_pong_sequence():
    got = [seq.frame_index(t, 4, start=0, mode=seq.PING_PONG) for t in range(-6, 13)]
    # period 2n-2 = 6: 0 1 2 3 2 1 | 0 1 2 3 2 1 ...
    pattern = [0, 1, 2, 3, 2, 1]
    assert got == [pattern[t % 6] for t in range(-6, 13)]
    assert [seq.frame_index(t, 1, start=0, mode=seq.PING_PONG) for t in range(-3, 4)] == [0] * 7
    assert [seq.frame_index(t, 2, start=0, mode=seq.PING_PONG) for t in range(0, 5)] == [0, 1, 0, 1, 0]


def test_speed_offset_and_fractions():
    assert seq.frame_index(10, 100, start=0, speed=0.5) == 5
    assert seq.frame_index(11, 100, start=0, speed=0.5) == 5     # 5.5 floors
    assert seq.frame_index(3, 100, start=0, speed=0.1, offset=0) == 0  # 0.30000000000000004
    assert 49 * (1 / 49) < 1.0
    assert seq.frame_index(49, 100, start=0, speed=1 / 49) == 1  # 0.9999999999999999 snaps to 1
    assert seq.frame_index(4, 10, start=1, speed=2, offset=1) == 7
    assert seq.frame_index(4, 10, start=1, speed=-1, offset=5, mode=seq.LOOP) == 2
    assert seq.frame_index(4, 10, start=1, speed=-1, offset=0, mode=seq.HOLD) == 0
    assert seq.frame_index(4, 10, start=1, speed=1, offset=-2.5) == 0  # 0.5 floors
    assert seq.frame_index(4, 10, start=1, speed=1, offset=-3.5, mode=seq.LOOP) == 9  # -0.5 -> -1


def test_speed_zero_freezes_on_offset():
    assert {seq.frame_index(t, 10, start=1, speed=0.0, offset=3) for t in range(-50, 50)} == {3}
    assert {seq.frame_index(t, 10, start=1, speed=0.0, offset=13, mode=seq.LOOP) for t in range(9)} == {3}


def test_bad_arguments():
    with pytest.raises(ValueError):
        seq.frame_index(1, 0)
    with pytest.raises(ValueError):
        seq.frame_index(1, 5, mode="BOUNCE")
    assert seq.frame_index(float("nan"), 5) == 0


# ---- discovery --------------------------------------------------------------------------

def test_discover_folder_natural_order_and_gaps(tmp_path):
    _touch(tmp_path, ["frame_0001.ply", "frame_0002.ply", "frame_0004.ply", "frame_0010.ply",
                      "notes.txt", "thumb.ply", "other_1.ply"])
    p = seq.discover(tmp_path)
    assert (p.prefix, p.suffix, p.digits, p.first, p.count) == ("frame_", ".ply", 4, 1, 10)
    assert p.filename(3) == "frame_0004.ply" and p.filename(9) == "frame_0010.ply"


def test_discover_unpadded_numbers_sort_numerically(tmp_path):
    _touch(tmp_path, ["s10.splat", "s2.splat", "s9.splat", "s1.splat"])
    p = seq.discover(tmp_path)
    assert (p.prefix, p.first, p.count, p.digits) == ("s", 1, 10, 1)
    assert [p.filename(i) for i in (0, 1, 9)] == ["s1.splat", "s2.splat", "s10.splat"]


def test_discover_from_file_picks_its_group(tmp_path):
    _touch(tmp_path, ["a_1.ply", "a_2.ply", "a_3.ply", "b_7.ply", "b_8.ply"])
    p = seq.discover(tmp_path / "b_8.ply")
    assert (p.prefix, p.first, p.count) == ("b_", 7, 2)
    assert seq.discover(tmp_path).prefix == "a_"  # the largest group wins for a folder
    _touch(tmp_path, ["take2_0005.ply"])
    assert seq.discover(tmp_path / "take2_0005.ply").prefix == "take2_"


def test_discover_errors_name_the_path(tmp_path):
    with pytest.raises(SplatFormatError, match="no numbered splat files"):
        seq.discover(tmp_path)
    _touch(tmp_path, ["scan.ply"])
    with pytest.raises(SplatFormatError, match="scan.ply.*no frame number"):
        seq.discover(tmp_path / "scan.ply")
    with pytest.raises(SplatFormatError, match="no such"):
        seq.discover(tmp_path / "absent")


# ---- cache ------------------------------------------------------------------------------

def _frame(n):
    return random_splats(n, degree=0, seed=n)


def test_cache_lru_eviction_keeps_budget_and_pinned():
    one = seq.splats_nbytes(_frame(100))
    cache = seq.FrameCache(3 * one)
    for i in range(3):
        cache.put(("f", i), _frame(100))
    cache.pin("obj", ("f", 0))
    cache.get(("f", 1))                      # 1 becomes most recent; LRU order: 0(pinned), 2, 1
    cache.put(("f", 3), _frame(100))
    assert cache.keys() == [("f", 0), ("f", 1), ("f", 3)]
    assert cache.nbytes == 3 * one <= cache.budget
    cache.set_budget(0)                       # only the pinned current frame survives
    assert cache.keys() == [("f", 0)]


def test_cache_signature_detects_rewritten_file():
    cache = seq.FrameCache(1 << 20)
    cache.put(("f", 0), _frame(10), signature=(1, 100))
    assert cache.get(("f", 0), (1, 100)) is not None
    assert cache.get(("f", 0), (2, 100)) is None


def test_read_ahead_fills_cache_and_stops(tmp_path):
    paths = []
    for i in range(4):
        path = tmp_path / f"f_{i}.ply"
        write(path, random_splats(50, degree=1, seed=i))
        paths.append(str(path))
    cache = seq.FrameCache(1 << 30)
    ahead = seq.ReadAhead(cache, read)
    ahead.request([((p, i), p, 0) for i, p in enumerate(paths)])
    assert ahead.wait_idle(30)
    assert sorted(k[1] for k in cache.keys()) == [0, 1, 2, 3]
    np.testing.assert_array_equal(cache.get((paths[2], 2)).positions, read(paths[2]).positions)
    thread = ahead._thread
    ahead.stop()
    assert not ahead.running and not thread.is_alive() and thread not in threading.enumerate()


def test_read_ahead_respects_budget(tmp_path):
    path = tmp_path / "f_0.ply"
    write(path, random_splats(50, degree=1, seed=0))
    size = seq.splats_nbytes(read(path))
    cache = seq.FrameCache(size - 1)
    ahead = seq.ReadAhead(cache, read)
    ahead.request([((str(path), 0), str(path), size)])
    assert ahead.wait_idle(30)
    assert cache.keys() == []
    ahead.stop()


# ---- bake folding -----------------------------------------------------------------------

def test_fold_color_matrix_matches_the_look_on_rendered_colour():
    rng = np.random.default_rng(3)
    splats = random_splats(200, degree=3, seed=3)
    m = np.hstack([rng.uniform(-0.5, 1.5, (3, 3)), rng.uniform(-0.2, 0.2, (3, 1))])
    dirs = rng.normal(size=(200, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    dc64, rest64 = splats.sh_dc.astype(np.float64), splats.sh_rest.astype(np.float64)
    # colour before the clamp: the look is applied to it (RenderItem.color_matrix)
    basis = _basis(dirs)
    colour = C0 * dc64 + np.einsum("nk,nkc->nc", basis, rest64) + 0.5
    want = colour @ m[:, :3].T + m[:, 3]
    dc2, rest2 = fold_color_matrix(splats.sh_dc, splats.sh_rest, m)
    got = C0 * dc2.astype(np.float64) + np.einsum("nk,nkc->nc", basis, rest2.astype(np.float64)) + 0.5
    # float32 storage of dc'/rest': |dc'| ~ 10 -> 1e-6 relative, times C0 and 16 terms
    np.testing.assert_allclose(got, want, atol=2e-5)


def _basis(dirs):
    return sh_basis(dirs, 3)[:, 1:]  # the higher bands; DC handled separately


def test_baked_splats_fold_scale_opacity_degree():
    splats = random_splats(20, degree=3, seed=1)
    item = RenderItem(splats=splats, splat_scale=2.0, opacity_scale=0.5, sh_degree=1)
    out = baked_splats(item)
    np.testing.assert_array_equal(out.scales, splats.scales * np.float32(2.0))  # power of 2: exact
    np.testing.assert_array_equal(out.opacities, splats.opacities * np.float32(0.5))
    assert out.sh_degree == 1
    np.testing.assert_array_equal(out.sh_rest, splats.sh_rest[:, :3])
    np.testing.assert_array_equal(out.positions, splats.positions)
    assert baked_splats(RenderItem(splats=splats, opacity_scale=5.0)).opacities.max() <= 1.0


def test_read_ahead_in_progress_is_awaited_not_decoded_twice(tmp_path):
    path = str(tmp_path / "f_0.ply")
    write(path, random_splats(50, degree=1, seed=0))
    started, release, loads = threading.Event(), threading.Event(), []

    def slow_read(p):  # a reader that takes as long as the test wants
        loads.append(p)
        started.set()
        release.wait(10)
        return read(p)

    cache = seq.FrameCache(1 << 30)
    ahead = seq.ReadAhead(cache, slow_read)
    ahead.request([((path, 0), path, 0)])
    assert started.wait(10)
    threading.Timer(0.2, release.set).start()
    ahead.wait_if_loading((path, 0))      # returns once the thread has put it
    assert cache.get((path, 0)) is not None and loads == [path]
    ahead.wait_if_loading(("other", 1))   # nothing loading: returns at once
    ahead.stop()
