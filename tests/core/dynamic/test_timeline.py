"""Scene frames -> capture time (core/dynamic/timeline.py)."""
from __future__ import annotations

import math

import pytest

from addon.core.dynamic import timeline
from addon.core.dynamic.timeline import HOLD, LOOP, PING_PONG, Mapping, capture_time


def test_real_time_from_the_start_frame():
    m = Mapping(time_start=0.0, time_end=2.0, start_frame=1.0, frames_per_unit=24.0)
    assert capture_time(m, 1.0) == 0.0
    assert capture_time(m, 25.0) == 1.0
    assert capture_time(m, 13.5) == pytest.approx(12.5 / 24.0)  # a motion-blur sub-frame
    assert capture_time(m, -100.0) == 0.0 and capture_time(m, 1000.0) == 2.0  # held


def test_segments_span_fifty_frames_each():
    assert timeline.default_frames_per_unit(timeline.SEGMENT, 24.0) == 50.0
    assert timeline.default_frames_per_unit(timeline.SECONDS, 30.0) == 30.0
    m = Mapping(time_start=0.0, time_end=3.0, start_frame=1.0, frames_per_unit=50.0)
    assert capture_time(m, 51.0) == 1.0 and capture_time(m, 126.0) == 2.5


@pytest.mark.parametrize("t, want", [(0.5, 0.5), (2.0, 0.0), (2.5, 0.5), (-0.5, 1.5)])
def test_loop_wraps(t, want):
    assert timeline.fold(t, 0.0, 2.0, LOOP) == pytest.approx(want)


@pytest.mark.parametrize("t, want", [(0.5, 0.5), (2.0, 2.0), (2.5, 1.5), (4.5, 0.5), (-0.5, 0.5)])
def test_ping_pong_reflects(t, want):
    assert timeline.fold(t, 0.0, 2.0, PING_PONG) == pytest.approx(want)


def test_a_keyed_capture_time_replaces_the_frame_and_is_folded():
    m = Mapping(time_start=1.0, time_end=3.0, capture_time=2.25, mode=HOLD)
    assert capture_time(m, 1.0) == capture_time(m, 500.0) == 2.25
    assert capture_time(Mapping(1.0, 3.0, capture_time=9.0), 1.0) == 3.0


def test_stiff_inputs_stay_in_range():
    for mode in (HOLD, LOOP, PING_PONG):
        assert timeline.fold(math.nan, 0.0, 2.0, mode) == 0.0
        assert timeline.fold(math.inf, 0.0, 2.0, mode) == 0.0
        assert timeline.fold(5.0, 1.0, 1.0, mode) == 1.0  # a one-moment capture
        assert 0.0 <= timeline.fold(1e300, 0.0, 2.0, mode) <= 2.0
    with pytest.raises(ValueError, match="unknown loop mode"):
        timeline.fold(0.0, 0.0, 1.0, "BOUNCE")
