"""guitar.ply by Blender 5.3's own `wm.ply_import`, with 4 faint splats added far out of view,
rendered by EEVEE (issue 45): what the bench and the test of Render > Leave Out Far Outliers
share. Each render runs in a child process of its own (a second EEVEE render in one process
crashed 5.3.0 here, and a process sometimes crashes on exit after writing its frame: the
frame decides).

    python -m testing.eevee_outliers DISTANCE OUT GUARD   (the child)
"""
from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import numpy as np

W, H = 160, 96
FAR_OPACITY = 0.05


def far_splats(splats, distance: float):
    """4 faint splats at `distance` x the capture's size from its middle: behind and beside the
    front camera, out of view."""
    lo, hi = np.percentile(splats.positions, [2, 98], axis=0)
    size = float(np.linalg.norm(hi - lo))
    far = splats.subset(np.arange(4))
    far.positions[:] = (lo + hi) / 2 + distance * size * np.array(
        [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    far.opacities[:] = FAR_OPACITY
    return far, lo, hi, size


def render(distance: float, out: Path, guard: bool) -> float:
    """In this process: the frame as OUT.exr; returns the capture's size."""
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
    scene = bpy.context.scene
    scene.splatline.render.native_outliers = guard
    splats = splats_from_pointcloud(obj.data)
    far, lo, hi, size = far_splats(splats, distance)
    if distance > 0:
        overwrite_pointcloud(obj.data, merge([splats, far]))
    bpy.context.view_layer.update()
    world = np.array(obj.matrix_world)
    centre = world[:3, :3] @ ((lo + hi) / 2) + world[:3, 3]
    add_camera(bpy, location=tuple(centre + (0.0, -2.2 * size, 0.0)), target=tuple(centre))
    scene.render.engine = "BLENDER_EEVEE"
    scene.eevee.taa_render_samples = 16
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = W, H, 100
    scene.render.film_transparent = True
    set_file_format(scene.render.image_settings, "OPEN_EXR")
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = str(out)
    bpy.ops.render.render(write_still=True)
    return size


# EEVEE 5.3.0 on a software GL (llvmpipe) aborts with glibc heap corruption or segfaults
# inside render() in a few per cent of processes under load, in a process that only imported
# numpy beside bpy too (Splatline not loaded; docs/rendering.md, Lighting). Such a child is
# run again, at most ATTEMPTS times in all; any other failure is not.
ATTEMPTS = 3
_HEAP_ABORT = ("corrupted size", "corrupted double-linked list", "malloc(): ", "free(): ", "double free")


def upstream_eevee_crash(run: subprocess.CompletedProcess) -> bool:
    """Whether a child died of that crash: killed by SIGSEGV, or by SIGABRT after glibc's heap
    check complained."""
    if run.returncode == -signal.SIGSEGV:
        return True
    return run.returncode == -signal.SIGABRT and any(m in run.stderr for m in _HEAP_ABORT)


def render_in_child(distance: float, out: Path, guard: bool, python: str = sys.executable):
    """(RGBA float32 frame, size, stderr) of one render in a child process; frame None when
    EEVEE wrote none. A child killed by EEVEE 5.3.0's own crash is run again (ATTEMPTS); the
    stderr then starts with a line for each such crash."""
    from testing.engine_scene import read_exr_parts
    from testing.paths import REPO

    crashes = []
    for _ in range(ATTEMPTS):
        run = subprocess.run([python, "-m", "testing.eevee_outliers", str(distance), str(out), str(int(guard))],
                             capture_output=True, text=True, cwd=REPO, timeout=600)
        if not upstream_eevee_crash(run):
            break
        crashes.append(f"EEVEE crashed in the child (signal {-run.returncode}): "
                       f"{run.stderr.strip().splitlines()[-1] if run.stderr.strip() else ''}\n")
    run.stderr = "".join(crashes) + run.stderr
    if crashes:
        print("".join(crashes), file=sys.stderr, end="")
    lines = [line for line in run.stdout.splitlines() if line.startswith("size ")]
    exr = out.with_suffix(".exr")
    if not lines or not exr.exists():
        return None, None, run.stderr
    return next(iter(read_exr_parts(exr).values())), float(lines[0].split()[1]), run.stderr


def covered_psnr(frame: np.ndarray, base: np.ndarray) -> tuple[float, int]:
    """PSNR of the pixels the base frame covers (alpha >= 0.5), and their count."""
    covered = base[..., 3] >= 0.5
    err = float(np.mean((frame[covered] - base[covered]) ** 2))
    return (float("inf") if err == 0 else 10 * np.log10(1.0 / err)), int(covered.sum())


if __name__ == "__main__":
    print(f"size {render(float(sys.argv[1]), Path(sys.argv[2]), bool(int(sys.argv[3])))}", flush=True)
