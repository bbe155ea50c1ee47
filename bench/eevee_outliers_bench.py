"""What a few far outlier splats do to Blender 5.3's EEVEE render of a real capture, with
Render > Leave Out Far Outliers off and on (issue 45).

    .venv-5.3/bin/python -m bench.eevee_outliers_bench

EEVEE stores splat centres quantised against the whole cloud's bounds (22 bits an axis, in
Blender's source): one splat far away widens the bounds and coarsens every centre. guitar.ply
by `wm.ply_import` (native), a front camera, 160x96, EEVEE 16 samples; then the same with 4
faint splats added far outside the view at D x the capture's size (testing/eevee_outliers.py).
Printed: PSNR of the covered pixels against the frame without outliers, for each setting.
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from testing.eevee_outliers import H, W, covered_psnr, render_in_child

DISTANCES = (10, 100, 1_000, 10_000, 100_000)  # x the capture's size


def main() -> None:
    from testing.blender_packages import use_bundled_packages

    use_bundled_packages()
    with tempfile.TemporaryDirectory() as tmp:
        base, size, _ = render_in_child(0, Path(tmp) / "base", guard=False)
        again, _, _ = render_in_child(0, Path(tmp) / "again", guard=False)
        if base is None or again is None:
            print("EEVEE wrote no frame")
            return
        psnr, covered = covered_psnr(again, base)
        print(f"guitar.ply (wm.ply_import), EEVEE 16 samples, {W}x{H}; size {size:.2f}; {covered} covered"
              f" pixels; no outliers, rendered again: {psnr:.1f} dB (EEVEE's own repeatability)")
        print(f"{'4 outliers at':>16}  {'guard off':>10}  {'guard on':>10}")
        for d in DISTANCES:
            cells = []
            for guard in (False, True):
                frame, _, _ = render_in_child(d, Path(tmp) / f"d{d}-{guard}", guard)
                cells.append("failed" if frame is None else f"{covered_psnr(frame, base)[0]:.1f} dB")
            print(f"{d:>9,} x size  {cells[0]:>10}  {cells[1]:>10}", flush=True)


if __name__ == "__main__":
    main()
    sys.exit(0)
