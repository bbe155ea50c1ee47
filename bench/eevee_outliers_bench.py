"""What a few far outlier splats do to Blender 5.3's EEVEE render of a real capture (issue 45).

    .venv-5.3/bin/python -m bench.eevee_outliers_bench

EEVEE stores splat centres quantised against the whole cloud's bounds (22 bits an axis, in
Blender's source): one splat far away widens the bounds and coarsens every centre. guitar.ply
by `wm.ply_import` (native), a front camera, 160x96, EEVEE 16 samples; then the same with 4
faint splats added far outside the view at D x the capture's size. Printed: PSNR of the covered
pixels against the frame without outliers, and the centre step the bounds imply
(bounds / 2^22). Each render runs in its own process (a second EEVEE render in one process
crashed 5.3.0 here, and a process sometimes crashes on exit after writing its frame).
"""
from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

DISTANCES = (0, -1, 10, 100, 1_000, 10_000, 100_000)  # x the capture's size; 0: none, -1: none again
W, H = 160, 96


def _render(distance: float, out: Path) -> float:
    import bpy

    from addon.blender.compat import set_file_format
    from addon.blender.data.pointcloud import overwrite_pointcloud, splats_from_pointcloud
    from addon.cli import blender_session
    from addon.core.edit import merge
    from testing.engine_scene import add_camera
    from testing.paths import SHARED_TESTDATA

    blender_session.start()
    bpy.ops.wm.ply_import(filepath=str(SHARED_TESTDATA / "guitar.ply"))
    obj = bpy.context.selected_objects[0]
    obj.rotation_euler = (-np.pi / 2, 0.0, 0.0)
    splats = splats_from_pointcloud(obj.data)
    lo, hi = np.percentile(splats.positions, [2, 98], axis=0)
    size = float(np.linalg.norm(hi - lo))
    if distance > 0:
        far = splats.subset(np.arange(4))
        far.positions[:] = (lo + hi) / 2 + distance * size * np.array(
            [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)  # behind, beside: out of view
        far.opacities[:] = 0.05
        overwrite_pointcloud(obj.data, merge([splats, far]))
    bpy.context.view_layer.update()
    world = np.array(obj.matrix_world)
    centre = world[:3, :3] @ ((lo + hi) / 2) + world[:3, 3]
    add_camera(bpy, location=tuple(centre + (0.0, -2.2 * size, 0.0)), target=tuple(centre))
    scene = bpy.context.scene
    scene.render.engine = "BLENDER_EEVEE"
    scene.eevee.taa_render_samples = 16
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = W, H, 100
    scene.render.film_transparent = True
    set_file_format(scene.render.image_settings, "OPEN_EXR")
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = str(out)
    bpy.ops.render.render(write_still=True)
    return size


def main(argv=()) -> None:
    if argv:  # one render, in this process
        distance, out = float(argv[0]), Path(argv[1])
        size = _render(distance, out)
        print(f"size {size}")
        return
    from testing.blender_packages import use_bundled_packages
    from testing.engine_scene import read_exr_parts

    use_bundled_packages()
    with tempfile.TemporaryDirectory() as tmp:
        frames, size = {}, None
        for d in DISTANCES:
            out = Path(tmp) / f"d{d}"
            run = subprocess.run([sys.executable, "-m", "bench.eevee_outliers_bench", str(d), str(out)],
                                 capture_output=True, text=True)
            lines = [line for line in run.stdout.splitlines() if line.startswith("size ")]
            # 5.3.0 may crash on exit after writing the frame: the frame decides
            if not lines or not out.with_suffix(".exr").exists():
                print(f"4 outliers at {d:>7,} x size: EEVEE failed (exit status {run.returncode})")
                continue
            size = float(lines[0].split()[1])
            frames[d] = next(iter(read_exr_parts(out.with_suffix(".exr")).values()))
        base = frames.get(0)
        if base is None:
            return
        covered = base[..., 3] >= 0.5
        print(f"guitar.ply (wm.ply_import), EEVEE 16 samples, {W}x{H}; size {size:.2f}; "
              f"{int(covered.sum())} covered pixels")
        for d, frame in frames.items():
            if d == 0:
                continue
            err = float(np.mean((frame[covered] - base[covered]) ** 2))
            psnr = float("inf") if err == 0 else 10 * np.log10(1.0 / err)
            if d < 0:
                print(f"no outliers, rendered again:   PSNR covered {psnr:6.1f} dB (EEVEE's own repeatability)")
                continue
            step = 2 * d * size / 2 ** 22
            print(f"4 outliers at {d:>7,} x size: PSNR covered {psnr:6.1f} dB   centre step ~{step:.2e}"
                  f" (capture size {size:.2f})")


if __name__ == "__main__":
    main(sys.argv[1:])
