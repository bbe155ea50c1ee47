"""Error against run time for the offscreen renderer (addon/gl), against the float64
reference (addon/core/reference.py, without early termination).

    python -m bench render        (or make bench)

Every row's error is against the exact reference (the 1/255 footprint), so the
capped-extent row shows what cutting quads at 3 sigma costs in error and saves in time.

Two scenes, one run: guitar (../shared/testdata/guitar.ply, 90,854 splats, SH degree 0)
and a generated 1M-splat scene (4 objects x 250,000 splats, SH degree 3, overlapping, so
the global sort interleaves them). Each row is a renderer and setting; PSNR and max abs
error are over premultiplied RGBA against the reference with the same setting; ms is
the median of RUNS frames after one warm-up. GL rows are timed colour-only (depth pass
off) except the row that says so, with the renderer's defaults (early termination on). Sizes are chosen so the whole table takes a few
minutes on 2 CPU cores with Mesa llvmpipe (software GL); on a real GPU the GL rows are
orders of magnitude faster, the reference is not.
"""
from __future__ import annotations

import time

import numpy as np

from addon.core import reference
from addon.core.axes import matrix_for
from addon.core.camera import Camera, look_at, simple_camera
from addon.core.formats import read
from testing.synth import shell_splats
from addon.core.scene import RenderItem, RenderOptions
from bench.common import median_ms, psnr, reaching
from testing.paths import SHARED_TESTDATA

RUNS = 5
TESTDATA = SHARED_TESTDATA
GUITAR_SIZE = (320, 480)
MILLION_SIZE = (256, 256)   # GL timing frame
MILLION_CROP = (64, 64)     # error frame: the centre crop (reference time is for it)


# -- scenes -------------------------------------------------------------------------------
def guitar_scene():
    splats = read(TESTDATA / "guitar.ply")
    world = np.eye(4)
    world[:3, :3] = matrix_for(splats.axes)
    item = RenderItem(splats, world=world, key=("guitar", 0))
    pos = splats.positions.astype(np.float64) @ world[:3, :3].T
    lo, hi = np.percentile(pos, 2, axis=0), np.percentile(pos, 98, axis=0)
    centre, size = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo))
    view = np.array([-1.0, 0.0, -0.15]) / np.linalg.norm([-1.0, 0.0, -0.15])
    w, h = GUITAR_SIZE
    cam = simple_camera(w, h, 40.0, look_at(centre - view * size * 1.25, centre),
                        near=0.01 * size, far=100 * size)
    return [item], cam, cam


def shell_object(n: int, seed: int, centre, radius: float) -> RenderItem:
    """A noisy sphere shell of small splats with degree-3 view-dependent colour."""
    world = np.eye(4)
    world[:3, 3] = centre
    return RenderItem(shell_splats(n, 3, seed, radius=radius), world=world, key=(f"shell{seed}", 0))


def million_scene(n: int = 1_000_000):
    centres = [(-0.6, 0, 0), (0.6, 0.3, 0.1), (0, -0.4, 0.5), (0.1, 0.5, -0.5)]
    items = [shell_object(n // 4, i, c, 0.7) for i, c in enumerate(centres)]
    w, h = MILLION_SIZE
    full = simple_camera(w, h, 50.0, look_at((0.5, -4.0, 1.2), (0, 0, 0)), near=0.1, far=100.0)
    cw, ch = MILLION_CROP
    x0, y0 = (w - cw) // 2, (h - ch) // 2
    crop = Camera(full.world_to_camera, cw, ch, full.fx, full.fy, full.cx - x0, full.cy - y0,
                  full.near, full.far)
    return items, full, crop


def with_degree(items, degree):
    return [RenderItem(i.splats, i.world, i.splat_scale, i.opacity_scale, degree, i.color_matrix, i.key)
            for i in items]


def gl_rows(has_sh: bool, extra: bool):
    """(label, options, SH degree cap or None, renderer kind)."""
    d = RenderOptions()
    rows = [("gl, defaults (32-bit keys)", d, None, "colour")]
    if extra:
        rows += [("gl, default + depth pass", d, None, "depth"),
                 ("gl, GL 3.3 fallback (CPU preprocess+sort)", d, None, "fallback")]
    # the defaults sort with numpy on a software GL and with compute shaders on a GPU
    # (gl/sort.sorts_on_gpu): one row for each, forced
    rows += [("gl, GPU sort", RenderOptions(gpu_sort=True), None, "colour"),
             ("gl, CPU sort", RenderOptions(gpu_sort=False), None, "colour"),
             ("gl, 16-bit keys", RenderOptions(key_bits=16), None, "colour"),
             ("gl, antialiased", RenderOptions(antialiased=True), None, "colour"),
             ("gl, capped extent (3 sigma)", RenderOptions(capped_extent=True), None, "colour")]
    if has_sh:
        rows += [(f"gl, SH degree {k}", d, k, "colour") for k in range(3)]
    return rows


def measure(items, time_cam, err_cam, renderers: dict, extra: bool, err_items=None):
    """Rows for one scene. err_items (default: items) are rendered on err_cam by both
    the reference and gl for the error columns; items on time_cam for the time."""
    err_items = items if err_items is None else err_items
    refs = {}

    def ref_for(options, degree):
        # The capped extent is a speed setting: its error is against the exact reference.
        key = (options.antialiased, degree)
        if key not in refs:
            refs[key] = reference.render(with_degree(err_items, degree) if degree is not None else err_items,
                                         err_cam, RenderOptions(antialiased=options.antialiased,
                                                                early_termination=False))
        return refs[key]

    out = []
    t = time.perf_counter()
    base = ref_for(RenderOptions(early_termination=False), None)
    ref_ms = 1000.0 * (time.perf_counter() - t)
    et = reference.render(err_items, err_cam, RenderOptions(early_termination=True))
    crop_note = "" if err_cam is time_cam else f" ({err_cam.width}x{err_cam.height} crop)"
    out.append((f"reference float64, 1 run{crop_note}", float("inf"), 0.0, ref_ms))
    out.append(("reference + early termination (T<1e-4)", psnr(et.rgba, base.rgba),
                float(np.abs(et.rgba - base.rgba).max()), float("nan")))
    has_sh = max(i.splats.sh_degree for i in items) > 0
    for label, options, degree, kind in gl_rows(has_sh, extra):
        r = renderers[kind]
        scene = with_degree(items, degree) if degree is not None else items
        err_scene = with_degree(err_items, degree) if degree is not None else err_items
        img = r.render(err_scene, err_cam, options).rgba
        ref = ref_for(options, degree)
        ms = median_ms(lambda: r.render(scene, time_cam, options), RUNS)
        out.append((label, psnr(img, ref.rgba), float(np.abs(img - ref.rgba).max()), ms))
    return out


def print_table(title, rows):
    print(f"\n{title}")
    print(f"{'renderer / setting':44s} {'PSNR dB':>8s} {'max abs':>9s} {'ms/frame':>10s}")
    for label, p, e, ms in rows:
        ps = "inf" if np.isinf(p) else f"{p:.1f}"
        mss = "-" if np.isnan(ms) else f"{ms:.0f}"
        print(f"{label:44s} {ps:>8s} {e:9.2e} {mss:>10s}", flush=True)


def main():
    from addon.gl import OffscreenRenderer

    start = time.perf_counter()
    with OffscreenRenderer(depth_pass=False) as colour, OffscreenRenderer() as depth, \
            OffscreenRenderer(depth_pass=False, compute=False) as fallback:
        renderers = {"colour": colour, "depth": depth, "fallback": fallback}
        print(f"GL: {colour.gl_info.get('GL_RENDERER')} ({colour.gl_info.get('GL_VERSION')})")
        if not colour.uses_compute:  # the "GPU sort" rows would silently be the fallback's
            print("WARNING: no GL 4.3 compute shaders here: every gl row runs the GL 3.3 fallback "
                  "(CPU preprocess and sort)")
        items, time_cam, err_cam = guitar_scene()
        w, h = GUITAR_SIZE
        print_table(f"guitar, 90,854 splats, SH 0, {w}x{h}; error and time on the same frame; "
                    f"gl ms = median of {RUNS}",
                    measure(items, time_cam, err_cam, renderers, True))
        items, time_cam, err_cam = million_scene()
        w, h = MILLION_SIZE
        cw, ch = MILLION_CROP
        near = reaching(items, err_cam, (0, 0, err_cam.width, err_cam.height), margin=0.0)
        kept = sum(i.splats.count for i in near)
        print_table(f"generated, 1,000,000 splats in 4 objects, SH 3; gl ms = median of {RUNS} on the "
                    f"full {w}x{h} frame (no depth-pass and fallback rows, to keep the bench short); error on "
                    f"its centre {cw}x{ch} crop, gl and reference rendering the same crop camera and "
                    f"the {kept:,} splats whose quad reaches it",
                    measure(items, time_cam, err_cam, renderers, False, near))
    print(f"\n(whole table: {time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
