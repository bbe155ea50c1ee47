"""Reference renderer speed on the real guitar capture (90,854 splats).

python -m bench.reference_bench   -> a table of median seconds per frame over
RUNS runs, with the ratio against the first row (measured in the same run).
"""
from __future__ import annotations


import numpy as np

from addon.core import formats
from addon.core.axes import matrix_for
from addon.core.camera import look_at, simple_camera
from addon.core.reference import render
from addon.core.scene import RenderItem, RenderOptions
from bench.common import median_s
from testing.paths import SHARED_TESTDATA

RUNS = 3
GUITAR = SHARED_TESTDATA / "guitar.ply"


def _scene():
    sp = formats.read(GUITAR)
    world = np.eye(4)
    world[:3, :3] = matrix_for(sp.axes)
    pts = sp.positions.astype(np.float64) @ world[:3, :3].T
    centre = np.median(pts, axis=0)
    reach = np.percentile(np.linalg.norm(pts - centre, axis=1), 90)
    return RenderItem(sp, world=world), look_at(centre + reach * np.array([0, -1.2, 0.3]), centre)


def main() -> None:
    item, w2c = _scene()
    rows = []
    for size in (128, 256):
        for et in (False, True):
            cam = simple_camera(size, size, 50.0, w2c)
            sec = median_s(lambda: render([item], cam, RenderOptions(early_termination=et)), RUNS)
            rows.append((f"{size}x{size}", "on" if et else "off", sec))
    base = rows[0][2]
    print(f"reference renderer, guitar ({item.splats.count} splats), median of {RUNS} runs")
    print(f"{'frame':>9} {'early term':>10} {'s/frame':>8} {'x base':>7}")
    for frame, et, sec in rows:
        print(f"{frame:>9} {et:>10} {sec:8.2f} {sec / base:7.2f}")


if __name__ == "__main__":
    main()
