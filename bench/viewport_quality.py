"""Viewport memory and image quality: bytes per splat the drawing path keeps on the GPU
(read from its textures: data and draw order, then the preprocess pass's view records),
and PSNR of its drawing (viewport/offscreen.py, RGBA32F target) against the float64
reference renderer. Part of `python -m bench viewport` (viewport_bench.main prints it).

Scenes: guitar.ply (90,854 splats, degree 0) with the object rotation its RDF axes get on
import, framed from the front at 320x240; a degree-3 scene: test64.ply and 3,000
generated degree-3 splats (testing/synth.random_splats) around it, 160x120.
"""
from __future__ import annotations

import math

import numpy as np

from bench.common import psnr
from testing.paths import SHARED_TESTDATA

TESTDATA = SHARED_TESTDATA


def _guitar():
    from addon.core.axes import matrix_for
    from addon.core.camera import simple_camera
    from addon.core.formats import read
    from addon.core.framing import capture_axes, clip_range, fit_distance, front_pose, robust_bounds
    from addon.core.scene import RenderItem

    splats = read(TESTDATA / "guitar.ply")
    world = np.eye(4)
    world[:3, :3] = matrix_for(splats.axes)
    points = splats.positions.astype(np.float64) @ world[:3, :3].T
    bounds = robust_bounds(points)
    up, forward = capture_axes(splats.axes, world)
    width, height, fov = 320, 240, 40.0
    tan_x = math.tan(math.radians(fov) / 2)
    distance = 0.5 * fit_distance(bounds, tan_x, tan_x * height / width)  # fill the frame
    near, far = clip_range(bounds, distance)
    pose = front_pose(bounds, up, forward, distance)
    cam = simple_camera(width, height, fov, np.linalg.inv(pose), near=near, far=far)
    return [RenderItem(splats, world)], cam


def _degree3(n: int = 3000):
    from addon.core.camera import look_at, simple_camera
    from addon.core.formats import read
    from testing.synth import random_splats
    from addon.core.scene import RenderItem

    capture = read(TESTDATA / "test64.ply")
    centre = capture.positions.astype(np.float64).mean(0)
    spread = float(np.linalg.norm(capture.positions.std(0)))
    s = random_splats(n, 3, seed=5)  # positions ~ N(0, 2): brought to the capture's size
    s.positions[:] = s.positions * np.float32(spread / 2.0) + centre.astype(np.float32)
    s.scales[:] *= np.float32(spread / 2.0)
    eye = centre + np.array([0.4, -1.0, 0.35]) * 2.5 * spread
    cam = simple_camera(160, 120, 50.0, look_at(eye, centre), near=0.01 * spread, far=100.0 * spread)
    return [RenderItem(capture), RenderItem(s)], cam


def _guitar_effects():
    """The guitar scene with a reveal, a displace and a grade: the reference renders the
    stack evaluated on the CPU, the viewport applies all three itself (handed over as
    the viewport's evaluation hands them: deferral.drawn_splats)."""
    from dataclasses import replace

    from addon.blender.viewport.effect_rows import on_gpu
    from addon.core.effects import Displace, Grade, Reveal, evaluate_stack
    from addon.core.effects.deferral import drawn_splats, split_stack

    (item,), cam = _guitar()
    splats = item.splats
    lo, mid, hi = np.quantile(splats.positions[:, 2], (0.1, 0.5, 0.9))
    stack = [Reveal(progress=float(mid), width=float(hi - lo) / 4, glow_strength=1.0),
             Displace(amplitude=0.02, frequency=2.0), Grade(low=float(lo), high=float(hi), amount=0.6)]
    on_cpu, deferred = split_stack(stack, on_gpu)
    assert len(deferred) == 3
    whole = replace(item, splats=evaluate_stack(splats, stack, 0.5).splats)
    part, handed = drawn_splats(evaluate_stack(splats, on_cpu, 0.5).splats, deferred, 0.5)
    drawn = replace(item, splats=part, deferred=handed, rest_positions=splats.positions, key=("guitar",))
    return [whole], cam, [drawn]


def quality() -> list[tuple[str, float, float, float]]:
    """(scene, PSNR dB, max abs error, covered fraction) of the viewport drawing; covered:
    pixels whose reference alpha exceeds 0.1 (the scene fills the frame, not a corner)."""
    from addon.blender.viewport import ViewportRenderer
    from addon.blender.viewport.offscreen import draw_camera
    from addon.core import reference
    from addon.core.scene import RenderOptions

    rows = []
    for name, (items, cam, *viewport_items) in (
            ("guitar (RDF transform), 320x240", _guitar()),
            ("guitar, reveal + displace + grade (in the viewport's preprocess)", _guitar_effects()),
            ("degree 3: test64 + 3,000 splats, 160x120", _degree3())):
        renderer = ViewportRenderer()
        # twice: a displace's new noise layers are drawn from the CPU's centres at first
        # (ViewportRenderer._settled), from the GPU's from the next frame that blends them
        for _ in range(2):
            drawn = draw_camera(viewport_items[0] if viewport_items else items, cam, renderer=renderer)
        renderer.close()
        # the viewport composites every splat: early termination (the final renderers'
        # default since 356e19f) would count its own error against the viewport
        ref = reference.render(items, cam, RenderOptions(early_termination=False)).rgba
        rows.append((name, psnr(drawn, ref), float(np.abs(drawn - ref).max()), float((ref[..., 3] > 0.1).mean())))
    return rows


def memory(n: int = 16384) -> dict:
    """Per-splat GPU bytes by texture at SH degree 3, n splats (whole texture rows)."""
    from addon.blender.viewport import ViewportRenderer
    from addon.blender.viewport.offscreen import draw_camera
    from addon.core.camera import look_at, simple_camera
    from addon.core.scene import RenderItem
    from addon.core.splats import SplatSet

    rng = np.random.default_rng(0)
    s = SplatSet.allocate(n, 3)
    s.positions[:] = rng.normal(0.0, 1.0, (n, 3))
    s.scales[:] = 0.01
    s.rotations[:] = (1.0, 0.0, 0.0, 0.0)
    s.opacities[:] = 0.5
    s.sh_rest[:] = rng.normal(0.0, 0.2, s.sh_rest.shape)
    cam = simple_camera(64, 48, 50.0, look_at((0.0, -30.0, 0.0), (0.0, 0.0, 0.0)), near=0.1, far=100.0)
    renderer = ViewportRenderer()
    draw_camera([RenderItem(s)], cam, renderer=renderer)
    sizes = {k: v / n for k, v in renderer.gpu.per_splat_bytes().items()}
    renderer.close()
    return sizes


def main() -> None:
    import bpy  # noqa: F401  (starts Blender)

    from testing.headless import ensure_gpu

    ensure_gpu()
    sizes = memory()
    data = {k: v for k, v in sizes.items() if not k.startswith("rec_")}
    records = {k: v for k, v in sizes.items() if k.startswith("rec_")}
    print("viewport GPU bytes per splat at SH degree 3: data "
          + ", ".join(f"{k} {v:.1f}" for k, v in data.items()) + f"; total {sum(data.values()):.1f} "
          f"(goal <= 128); view records {sum(records.values()):.1f} (preprocess output)")
    for name, db, err, covered in quality():
        print(f"viewport vs float64 reference, {name}: PSNR {db:.1f} dB, max error {err:.2e} "
              f"({covered:.0%} of pixels covered)", flush=True)


if __name__ == "__main__":
    main()
