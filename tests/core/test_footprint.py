"""The footprint, pinned analytically: a single opaque splat lights exactly the pixel
centres inside its alpha = 1/255 contour, m2 = d^T conic d <= 2 ln(255 o) (3.33 sigma
at o = 1), and none beyond it, in the reference and in every fast path. The conic comes
from core/preprocess.py (pinned on its own by test_reference*.py); what is tested here is
which pixels a splat reaches. With the capped speed setting, the contour is cut at the
3-sigma square quad instead.

The reference is exact. The GPU paths compute m2 in float32: a pixel centre within
float32 rounding of the contour (relative 1e-3 here, far above rounding) may go
either way, so those pixels are left out of the GPU comparison, and only those.
"""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.scene import RenderItem, RenderOptions
from testing.footprint_scenes import (PATHS, camera, contour_pixels, gl, gl33, gpu_ready,  # noqa: F401
                             render_rgba, ring_pixels, splats)

NEAR_CONTOUR = 1e-3  # relative margin of m2 to the contour that float32 may flip


def _scene():
    return [RenderItem(splats([(1.0, 1.0, 1.0)]))], camera()


def _lit(path, request, items, cam, capped=False) -> np.ndarray:
    """Alpha > 0 per pixel after drawing items through one renderer."""
    return render_rgba(path, request, items, cam, RenderOptions(capped_extent=capped))[..., 3] > 0


def test_scene_has_a_ring_beyond_three_sigma():
    items, cam = _scene()
    inside, margin = contour_pixels(items[0], cam)
    ring = ring_pixels(items[0], cam)
    assert 300 < inside.sum() and not (inside[0].any() or inside[-1].any() or inside[:, 0].any()
                                      or inside[:, -1].any())  # the whole contour is in the frame
    assert (ring & (margin > NEAR_CONTOUR * 11.0)).sum() >= 8  # 11 = 2 ln 255, the contour


@pytest.mark.parametrize("path", PATHS)
def test_opaque_splat_lights_exactly_its_contour(path, request):
    items, cam = _scene()
    inside, margin = contour_pixels(items[0], cam)
    lit = _lit(path, request, items, cam)
    sure = margin > NEAR_CONTOUR * 2.0 * np.log(255.0) if path != "reference" else np.ones_like(lit)
    wrong = (lit != inside) & sure
    assert not wrong.any(), (f"{path}: {int((wrong & inside).sum())} pixels inside the 1/255 "
                             f"contour unlit, {int((wrong & ~inside).sum())} beyond it lit")
    assert lit[ring_pixels(items[0], cam) & sure].all()


@pytest.mark.parametrize("path", PATHS)
def test_capped_extent_stops_at_three_sigma(path, request):
    """The speed setting: the same contour, cut at the square quad of 3 sigma."""
    items, cam = _scene()
    inside, margin = contour_pixels(items[0], cam)
    expect = inside & ~ring_pixels(items[0], cam)
    lit = _lit(path, request, items, cam, capped=True)
    sure = margin > NEAR_CONTOUR * 2.0 * np.log(255.0) if path != "reference" else np.ones_like(lit)
    if path != "reference":  # float32 may also flip a centre on the quad's edge
        from addon.core.preprocess import project

        p = project(items[0], cam)
        ys, xs = np.mgrid[0:cam.height, 0:cam.width] + 0.5
        edge = np.minimum(np.abs(np.abs(xs - p.means2d[0, 0]) - p.radius[0]),
                          np.abs(np.abs(ys - p.means2d[0, 1]) - p.radius[0]))
        sure &= edge > 1e-3
    assert not ((lit != expect) & sure).any()
