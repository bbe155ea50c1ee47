"""How much of the frame the orbit's subject fills, per frame, framed the old way (the
percentile box of every centre, front by the broad face and the file's camera) and the new
(the box of the splats that show, core/visible_bounds.py; front from the side the splats
face, core/facing.py), in the same run: guitar.ply, test64.ply, a generated capture in a
faint halo 5x its size (testing/framing_captures.py) and a hemisphere photographed from its
back (in the file's frame). Frames rendered by the float64 reference at 320x180 (the
issue's size), 50 mm lens, the command line's orbit of 8 frames (45 degrees apart); fill as the tests measure
it: the covered (alpha > 0.5) pixels' bounding rectangle's larger side over the frame's
shorter side. Run: .venv/bin/python -m bench framing
"""
from __future__ import annotations

import math
import time

import numpy as np

from addon.core import facing, formats, framing
from addon.core.axes import matrix_for
from addon.core.camera import camera_from_params, rigid_inverse
from addon.core.reference import render
from addon.core.scene import RenderItem, RenderOptions
from addon.core.visible_bounds import visible_bounds
from bench.common import wall_and_cpu
from testing.framing_captures import alpha_fill, haloed_capture, one_sided_shell
from testing.paths import SHARED_TESTDATA

W, H, FRAMES = 320, 180, 8
TANS = (18.0 / 50.0, 18.0 / 50.0 * H / W)  # 36 mm sensor, 50 mm, AUTO fit on the width


def captures():
    yield "guitar.ply", formats.read(SHARED_TESTDATA / "guitar.ply")
    yield "test64.ply", formats.read(SHARED_TESTDATA / "test64.ply")
    yield "halo (subject + halo 5x)", haloed_capture()
    yield "shell facing back", one_sided_shell(facing_deg=180.0)


def orbit(splats, new: bool):
    """The command line's orbit poses (capture_camera.add_framing_camera's steps) and the
    front's look direction, with the new framing or the old."""
    rotation = np.eye(4)
    rotation[:3, :3] = matrix_for(splats.axes)
    points = splats.positions.astype(np.float64) @ rotation[:3, :3].T
    up, ahead = framing.capture_axes(splats.axes, rotation)
    if new:
        bounds = visible_bounds(points, splats.opacities, splats.scales)
        normals, flatness = facing.splat_normals(splats.rotations, splats.scales, rotation)
        faces = facing.facing(points, normals, flatness * splats.opacities, bounds.centre, up)
    else:
        bounds, faces = framing.robust_bounds(points), None
    front = framing.front_direction(points, bounds, up, ahead, faces)
    distance = framing.fill_distance(bounds, up, front, *TANS, azimuths=framing.orbit_azimuths())
    poses = framing.orbit_poses(bounds, up, front, distance, FRAMES)
    return poses, framing.clip_range(bounds, distance), front, rotation


def fills(splats, new: bool) -> tuple[list[float], np.ndarray]:
    poses, (near, far), front, rotation = orbit(splats, new)
    item = RenderItem(splats, world=rotation, sh_degree=0)
    out = []
    for pose in poses:
        camera = camera_from_params(rigid_inverse(pose), resolution_x=W, resolution_y=H,
                                    clip_start=near, clip_end=far)
        out.append(alpha_fill(render([item], camera, RenderOptions()).rgba[..., 3]))
    return out, front


def framing_cost(count: int = 1_000_000, runs: int = 5) -> None:
    """CPU of the framing's reading of a `count`-splat capture, old and new (the new adds
    the visible box, the normals of a sample and the facing), medians of `runs`."""
    splats = haloed_capture(subject=count * 94 // 100, halo=count * 6 // 100)
    rotation = np.eye(4)
    rotation[:3, :3] = matrix_for(splats.axes)
    points = splats.positions.astype(np.float64) @ rotation[:3, :3].T
    up, ahead = framing.capture_axes(splats.axes, rotation)

    def old(_):
        bounds = framing.robust_bounds(points)
        framing.front_direction(points, bounds, up, ahead)

    def new(_):
        bounds = visible_bounds(points, splats.opacities, splats.scales)
        stride = facing.sample_stride(len(points))
        normals, flatness = facing.splat_normals(splats.rotations[::stride], splats.scales[::stride],
                                                 rotation)
        faces = facing.facing(points[::stride], normals, flatness * splats.opacities[::stride],
                              bounds.centre, up)
        framing.front_direction(points, bounds, up, ahead, faces)

    (_, before), (_, after) = wall_and_cpu(old, runs), wall_and_cpu(new, runs)
    print(f"framing a {count:,}-splat capture (bounds and front), CPU s, median of {runs}: "
          f"old {before:.3f}, new {after:.3f} (+{after - before:.3f})")


def main():
    framing_cost()
    print(f"orbit fill per frame ({FRAMES} frames, {W}x{H}, alpha > 0.5), old framing / new; "
          f"front: azimuth of the front view's look, degrees counter-clockwise from +y (Blender)")
    for name, splats in captures():
        start = time.perf_counter()
        rows = {}
        for new in (False, True):
            values, front = fills(splats, new)
            rows[new] = values, math.degrees(math.atan2(-front[0], front[1]))
        print(f"{name} ({splats.count} splats, {time.perf_counter() - start:.0f} s)")
        for new, label in ((False, "old"), (True, "new")):
            values, azimuth = rows[new]
            print(f"  {label}: front {azimuth:7.1f}  fill {min(values):.3f}-{max(values):.3f}  "
                  + " ".join(f"{v:.2f}" for v in values))


if __name__ == "__main__":
    main()
