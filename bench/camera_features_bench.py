"""Camera features on the offscreen renderer: depth of field, motion blur, equirect.

    python -m bench camera_features                          (full size: 500k splats, 1920x1080)
    python -m bench.camera_features_bench --splats 50000 --size 480x270   (a quick run)

One generated scene (shells of degree-2 splats, `--splats` in all) and one function per
row, each taking (renderer, scene) and returning the row's figures, so the rows can be
folded into another table (bench/final_frame_bench.py):
- ms/frame: median of RUNS (>= 3) full frames, colour only (no depth pass), after a warm-up.
- PSNR and max abs error over premultiplied RGBA against the float64 reference with the
  same feature. The reference is too slow for a whole 1080p frame of 500k splats, so the
  error is over crops (Crop), rendered exactly with reference.render(window=...): the
  frame's own projection, only those pixels; the GL frame is cropped the same way. Each
  crop's reference gets only the splats whose quad can reach it (the others add nothing).
- DOF also states the approximation's own error: the CoC-widened reference against the
  many-sample lens reference (the mean of LENS_SAMPLES exact pinhole renders from points
  spread over the aperture, core/dof.lens_camera), beside the pinhole's error against it.
- Motion blur: 8 sub-frames (object turning, camera moving), each rendered and averaged
  with equal weights (core/shutter.Average); its reference is the same average of
  reference renders. ms/frame counts all 8 renders.
The "colour only" row is the same scene and camera without any feature, measured in the
same run, for the ratios.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import statistics
import time
from dataclasses import dataclass

import numpy as np

from addon.core import dof, reference, shutter
from addon.core.camera import Camera, equirect_camera, look_at, simple_camera
from addon.core.equirect import seam_shifts
from addon.core.project import project
from addon.core.scene import RenderItem, RenderOptions
from addon.core.splats import SplatSet

RUNS = 3
LENS_SAMPLES = 64
BLUR_SAMPLES = 8


@dataclass
class Crop:
    label: str
    window: tuple  # x, y, width, height in frame pixels


@dataclass
class Scene:
    items: list
    camera: Camera          # perspective, looking at the shells
    panorama: Camera        # equirect, from inside the shells
    size: tuple


# -- the scene ------------------------------------------------------------------------------
def shell(n: int, seed: int, centre, radius: float) -> RenderItem:
    """A noisy sphere shell of small degree-2 splats (view-dependent colour)."""
    rng = np.random.default_rng(seed)
    s = SplatSet.allocate(n, 2)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    s.positions[:] = d * radius * (1 + rng.normal(0, 0.03, (n, 1)))
    s.scales[:] = np.exp(rng.normal(np.log(radius * 0.01), 0.4, (n, 3)))
    q = rng.normal(size=(n, 4))
    s.rotations[:] = q / np.linalg.norm(q, axis=1, keepdims=True)
    s.opacities[:] = rng.beta(2, 1, n)
    s.sh_dc[:] = d * 0.8 + rng.normal(0, 0.3, (n, 3))
    s.sh_rest[:] = rng.normal(0, 0.15, s.sh_rest.shape)
    world = np.eye(4)
    world[:3, 3] = centre
    return RenderItem(s, world=world, key=(f"shell{seed}", 0))


def make_scene(n: int, size: tuple) -> Scene:
    """Shells at several depths (so DOF has near, focused and far splats) and a large
    one around the origin that the panorama sits inside."""
    specs = [((0.0, 0.0, 0.0), 4.0, 0.4), ((-0.8, -1.5, 0.2), 0.6, 0.15),
             ((0.9, 0.0, -0.1), 0.7, 0.15), ((0.2, 2.5, 0.5), 1.0, 0.3)]
    items = [shell(max(1, int(n * share)), i, c, r) for i, (c, r, share) in enumerate(specs)]
    w, h = size
    camera = simple_camera(w, h, 60.0, look_at((0.3, -3.2, 0.6), (0.2, 0.5, 0.1)), near=0.05, far=100.0)
    panorama = equirect_camera(look_at((0.1, -0.2, 0.05), (0.1, 1.0, 0.05)), w, h, near=0.05, far=100.0)
    return Scene(items, camera, panorama, size)


def default_crops(size) -> list:
    w, h = size
    cw, ch = max(16, w // 10), max(16, h // 10)
    return [Crop("centre", ((w - cw) // 2, (h - ch) // 2, cw, ch))]


def panorama_crops(size) -> list:
    """Centre, the seam (the left edge) and the pole (the top rows)."""
    w, h = size
    cw, ch = max(16, w // 10), max(16, h // 10)
    return default_crops(size) + [Crop("seam", (0, (h - ch) // 2, cw // 2, ch)),
                                  Crop("pole", ((w - cw) // 2, 0, cw, ch // 2))]


# -- measuring ------------------------------------------------------------------------------
def median_ms(fn, runs: int = RUNS) -> float:
    fn()  # warm-up: uploads, shader compilation
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return 1000.0 * statistics.median(times)


def psnr(a, b) -> float:
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return float("inf") if mse == 0 else 10.0 * np.log10(1.0 / mse)


def reaching(items, camera, window, margin: float = 2.0) -> list:
    """The items cut to the splats whose quad (or seam copy) reaches the window."""
    x, y, w, h = window
    out = []
    for item in items:
        p = project(item, camera)
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


def crop(image, window):
    x, y, w, h = window
    return image[y:y + h, x:x + w]


def errors(frames: dict, refs: dict) -> tuple:
    """(PSNR over all crops together, max abs error) of gl crops against reference crops."""
    gl = np.concatenate([frames[k].reshape(-1, 4) for k in refs])
    ref = np.concatenate([refs[k].reshape(-1, 4) for k in refs])
    return psnr(gl, ref), float(np.abs(gl.astype(np.float64) - ref).max())


def reference_crops(items, camera, crops) -> dict:
    return {c.label: reference.render(reaching(items, camera, c.window), camera,
                                      window=c.window).rgba for c in crops}


# -- the rows: each (renderer, scene) -> figures -----------------------------------------------
def row_colour(renderer, scene: Scene) -> dict:
    crops = default_crops(scene.size)
    frame = renderer.render(scene.items, scene.camera).rgba
    refs = reference_crops(scene.items, scene.camera, crops)
    p, e = errors({c.label: crop(frame, c.window) for c in crops}, refs)
    return {"ms": median_ms(lambda: renderer.render(scene.items, scene.camera)), "psnr": p, "max": e}


def dof_camera(scene: Scene) -> Camera:
    """f/1.4 on a 30 mm-equivalent lens radius, focused on the middle shell."""
    focus = float(scene.camera.project(np.array([[0.9, 0.0, -0.1]]))[0, 2])
    return dataclasses.replace(scene.camera, defocus=dof.Defocus(0.03, focus))


def row_dof(renderer, scene: Scene, lens_samples: int = LENS_SAMPLES) -> dict:
    cam = dof_camera(scene)
    crops = default_crops(scene.size)
    frame = renderer.render(scene.items, cam).rgba
    refs = reference_crops(scene.items, cam, crops)
    p, e = errors({c.label: crop(frame, c.window) for c in crops}, refs)
    lens = _lens_reference(scene.items, cam, crops, lens_samples)
    pinhole = reference_crops(scene.items, dataclasses.replace(cam, defocus=None), crops)
    lp, le = errors(refs, lens)
    pp, _ = errors(pinhole, lens)
    return {"ms": median_ms(lambda: renderer.render(scene.items, cam)), "psnr": p, "max": e,
            "lens_psnr": lp, "lens_max": le, "pinhole_lens_psnr": pp, "lens_samples": lens_samples}


def _lens_reference(items, cam, crops, samples) -> dict:
    """Mean of exact pinhole reference renders over `samples` lens points (per crop)."""
    out = {}
    for c in crops:
        near = reaching(items, cam, c.window, margin=4.0)  # the widened quad covers every shift
        frames = [reference.render(near, dof.lens_camera(cam, p), window=c.window).rgba
                  for p in dof.lens_samples(samples)]
        out[c.label] = np.mean(np.asarray(frames, np.float64), axis=0)
    return out


def moved(scene: Scene, time: float):
    """Items and camera at `time` (in frames, 0 = the frame): the big shell turning
    10 degrees per frame about z, the camera dollying 0.2 per frame along x."""
    a = math.radians(10.0) * time
    turn = np.eye(4)
    turn[:2, :2] = [[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]
    items = [dataclasses.replace(scene.items[0], world=turn @ scene.items[0].world)] + scene.items[1:]
    dolly = np.eye(4)
    dolly[0, 3] = -0.2 * time  # world_to_camera of a camera moved +x
    return items, dataclasses.replace(scene.camera, world_to_camera=scene.camera.world_to_camera @ dolly)


def row_motion_blur(renderer, scene: Scene, samples: int = BLUR_SAMPLES) -> dict:
    times = shutter.sub_frame_times(0, 0.5, "CENTER", samples)
    states = [moved(scene, t) for t in times]
    crops = default_crops(scene.size)

    def blurred():
        avg = shutter.Average(samples)
        for items, cam in states:
            avg.add(renderer.render(items, cam).rgba)
        return avg.result()

    frame = blurred()
    refs = {}
    for c in crops:
        avg = shutter.Average(samples)
        for items, cam in states:
            avg.add(reference.render(reaching(items, cam, c.window), cam, window=c.window).rgba)
        refs[c.label] = avg.result()
    p, e = errors({c.label: crop(frame, c.window) for c in crops}, refs)
    return {"ms": median_ms(blurred), "psnr": p, "max": e, "samples": samples}


def row_equirect(renderer, scene: Scene) -> dict:
    crops = panorama_crops(scene.size)
    frame = renderer.render(scene.items, scene.panorama).rgba
    refs = reference_crops(scene.items, scene.panorama, crops)
    out = {"ms": median_ms(lambda: renderer.render(scene.items, scene.panorama))}
    out["psnr"], out["max"] = errors({c.label: crop(frame, c.window) for c in crops}, refs)
    for c in crops:
        out[f"psnr_{c.label}"] = psnr(crop(frame, c.window), refs[c.label])
    return out


ROWS = (("colour only", row_colour), ("+ DOF", row_dof),
        (f"+ motion blur ({BLUR_SAMPLES} samples)", row_motion_blur), ("equirect", row_equirect))


# -- the table ------------------------------------------------------------------------------
def print_row(label: str, fig: dict, base_ms: float) -> None:
    ps = "inf" if math.isinf(fig["psnr"]) else f"{fig['psnr']:.1f}"
    print(f"{label:32s} {fig['ms']:10.0f} {fig['ms'] / base_ms:6.2f}x {ps:>8s} {fig['max']:9.2e}", flush=True)
    extra = {k: v for k, v in fig.items() if k not in ("ms", "psnr", "max")}
    if extra:
        print("    " + ", ".join(f"{k} {_figure(k, v)}" for k, v in extra.items()), flush=True)


def _figure(name: str, value) -> str:
    if not isinstance(value, float):
        return str(value)
    return f"{value:.2e}" if "max" in name else f"{value:.1f}"


def main(argv=None) -> None:
    from addon.gl import OffscreenRenderer

    parser = argparse.ArgumentParser(prog="camera_features_bench")
    parser.add_argument("--splats", type=int, default=500_000)
    parser.add_argument("--size", default="1920x1080")
    args = parser.parse_args([] if argv is None else argv)
    size = tuple(int(v) for v in args.size.lower().split("x"))
    start = time.perf_counter()
    scene = make_scene(args.splats, size)
    n = sum(i.splats.count for i in scene.items)
    with OffscreenRenderer(depth_pass=False) as renderer:
        print(f"GL: {renderer.gl_info.get('GL_RENDERER')}; {n:,} splats, SH 2, {size[0]}x{size[1]}; "
              f"ms = median of {RUNS} colour-only frames; error vs the float64 reference on crops "
              f"(centre {default_crops(size)[0].window[2:]}, equirect also seam and pole)")
        print(f"{'row':32s} {'ms/frame':>10s} {'ratio':>7s} {'PSNR dB':>8s} {'max abs':>9s}")
        base = None
        for label, row in ROWS:
            fig = row(renderer, scene)
            base = base or fig["ms"]
            print_row(label, fig, base)
    print(f"(whole table: {time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    import sys

    main(sys.argv[1:])
