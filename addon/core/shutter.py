"""Motion blur as a box shutter: the frame is the average of renders at sub-frame times.

Blender's settings: the shutter is open for `shutter` frames; its position says where the
frame's own time sits in that interval: START (the shutter opens at the frame), CENTER
(the frame is the middle), END (it closes at the frame). The N times are the midpoints
of N equal slices of the open interval, each weighted 1/N, and the average is summed in
float64 in time order. Every input is the frame number and the scene's settings, so a
frame renders to the same bits whichever other frames the same process rendered before
it (farm splits). Blender's shutter curve is not modelled (the shutter is a box).
"""
from __future__ import annotations

import math

import numpy as np

POSITIONS = ("START", "CENTER", "END")


def sub_frame_times(frame: int, shutter: float, position: str, samples: int) -> list[float]:
    """The `samples` scene times (in frames) to evaluate for `frame`."""
    if position not in POSITIONS:
        raise ValueError(f"shutter position {position!r} is not one of {POSITIONS}")
    if samples < 1:
        raise ValueError(f"motion blur needs at least 1 sample, not {samples}")
    opens = {"START": 0.0, "CENTER": -0.5, "END": -1.0}[position] * shutter
    return [frame + opens + shutter * (i + 0.5) / samples for i in range(samples)]


def split_time(time: float) -> tuple[int, float]:
    """A scene time -> (frame, subframe in [0, 1)), as Scene/RenderEngine.frame_set take it."""
    whole = math.floor(time)
    return int(whole), float(time - whole)


def nearest_to_middle(times: list[float]) -> int:
    """Index of the sample nearest the middle of the open shutter (the depth pass's)."""
    middle = 0.5 * (times[0] + times[-1])
    return min(range(len(times)), key=lambda i: abs(times[i] - middle))


class Average:
    """Equal-weight average of frames, summed in float64 in the order they are added."""

    def __init__(self, count: int):
        self.count, self.added, self.total = count, 0, None

    def add(self, image: np.ndarray) -> None:
        image = np.asarray(image, np.float64)
        self.total = image.copy() if self.total is None else self.total + image
        self.added += 1

    def result(self) -> np.ndarray:
        if self.added != self.count:
            raise RuntimeError(f"averaged {self.added} of {self.count} frames")
        return (self.total / self.count).astype(np.float32)
