"""timeline.capture_time: scene frame -> capture time, LOOP / HOLD / PINGPONG."""
from __future__ import annotations

from types import SimpleNamespace

import pytest

from addon.core.dynamic.timeline import capture_time

SEGMENTS = SimpleNamespace(t_start=0.0, t_end=3.0, unit="segment")
SECONDS = SimpleNamespace(t_start=2.0, t_end=6.0, unit="seconds")


def _t(frame, capture=SEGMENTS, **kw):
    return capture_time(frame, start_frame=1, scene_fps=24, capture=capture, **kw)


def test_defaults_a_segment_per_50_frames_and_real_time_seconds():
    assert [_t(f) for f in (1, 26, 51, 101, 126)] == [0.0, 0.5, 1.0, 2.0, 2.5]
    assert [_t(f, SECONDS) for f in (1, 13, 25, 73)] == [2.0, 2.5, 3.0, 5.0]


@pytest.mark.parametrize("mode,expect", [
    ("LOOP", [0.0, 2.5, 0.0, 0.5, 2.5]),
    ("HOLD", [0.0, 2.5, 3.0, 3.0, 0.0]),
    ("PINGPONG", [0.0, 2.5, 3.0, 2.5, 0.5]),
])
def test_modes(mode, expect):
    frames = (1, 126, 151, 176, -24)  # start, inside, the end, past it, before the start
    assert [_t(f, mode=mode) for f in frames] == pytest.approx(expect)


def test_speed_and_frames_per_unit():
    assert _t(26, speed=2.0) == 1.0
    assert _t(11, frames_per_unit=10) == 1.0
    assert _t(11, SECONDS, frames_per_unit=10, speed=0.5) == 2.5


def test_bad_arguments():
    with pytest.raises(ValueError):
        _t(1, mode="BOUNCE")
    with pytest.raises(ValueError):
        _t(1, frames_per_unit=0)
    assert _t(99, SimpleNamespace(t_start=1.0, t_end=1.0, unit="seconds")) == 1.0
