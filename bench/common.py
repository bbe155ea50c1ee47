"""What the bench tables share: medians of timed runs, PSNR, crops of a frame, and cutting
a scene down to the splats that reach a window of the frame (the reference's cost grows
with the splats it is given; the others add nothing to those pixels)."""
from __future__ import annotations

import dataclasses
import math
import statistics
import time

import numpy as np

from addon.core.equirect import seam_shifts
from addon.core.preprocess import project


def psnr(a, b) -> float:
    """PSNR in dB of a against b for values in [0, 1] (inf where they are equal)."""
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return math.inf if mse == 0 else 10.0 * math.log10(1.0 / mse)


def wall_and_cpu(fn, runs: int) -> tuple[float, float]:
    """(wall s, CPU s of all this process's threads) medians of `runs` calls fn(i). CPU
    time is what a shared machine disturbs less; wall time includes waiting for a core."""
    wall, cpu = [], []
    for i in range(runs):
        t, c = time.perf_counter(), time.process_time()
        fn(i)
        cpu.append(time.process_time() - c)
        wall.append(time.perf_counter() - t)
    return statistics.median(wall), statistics.median(cpu)


def median_s(fn, runs: int, warm_up: bool = False) -> float:
    """Median wall seconds of `runs` calls fn() (after one untimed call if warm_up)."""
    if warm_up:
        fn()
    return wall_and_cpu(lambda _i: fn(), runs)[0]


def median_ms(fn, runs: int, warm_up: bool = True) -> float:
    """median_s in milliseconds; by default after a warm-up (uploads, shader compiles)."""
    return 1000.0 * median_s(fn, runs, warm_up)


def crop(image, window):
    """The (x, y, width, height) window of a top-down image."""
    x, y, w, h = window
    return image[y:y + h, x:x + w]


def reaching(items, camera, window, margin: float = 2.0, antialiased: bool = False) -> list:
    """The items cut to the splats whose quad (or, for an equirect camera, its seam copy)
    reaches the window, widened by `margin` pixels; keys dropped (the cut is a new set)."""
    x, y, w, h = window
    out = []
    for item in items:
        p = project(item, camera, antialiased=antialiased)
        u, v, r = p.means2d[:, 0], p.means2d[:, 1], p.radius + margin
        with np.errstate(invalid="ignore"):
            rows = (v + r >= y) & (v - r <= y + h)
            cols = (u + r >= x) & (u - r <= x + w)
            if camera.equirect:
                for idx, shift in seam_shifts(u, p.radius, camera):
                    hit = np.zeros_like(cols)
                    hit[idx] = (u[idx] + shift + r[idx] >= x) & (u[idx] + shift - r[idx] <= x + w)
                    cols |= hit
        keep = p.valid & rows & cols
        out.append(dataclasses.replace(item, splats=item.splats.subset(keep), key=None))
    return out
