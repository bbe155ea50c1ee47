"""Single- and two-splat scenes whose answers are known analytically, shared by
test_footprint.py and test_tie_order.py, and the renderers they run through."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core import reference
from addon.core.camera import look_at, simple_camera
from addon.core.preprocess import project
from addon.core.scene import RenderItem, RenderOptions
from addon.core.sh import C0
from addon.core.splats import SplatSet

SIZE = (64, 48)


def camera():
    """Looks along +y at the origin from 4 units away: splat x is screen u, splat z is -v."""
    return simple_camera(*SIZE, 40.0, look_at((0.0, -4.0, 0.0), (0.0, 0.0, 0.0)), near=0.1, far=50.0)


def splats(rgbs, position=(0.013, 0.0, -0.007), scales=(0.28, 0.12, 0.1),
           quat=(0.996, 0.0, 0.087, 0.0), opacity=1.0) -> SplatSet:
    """One splat per colour, all with the same centre (so exactly equal depths) and shape.
    Defaults: sigmas of about 6 x 2.5 px, major axis 10 degrees off screen u, so the
    ring between 3 sigma and the 1/255 contour sticks out of a 3-sigma square quad."""
    n = len(rgbs)
    s = SplatSet.allocate(n, 0)
    s.positions[:] = position
    s.scales[:] = scales
    s.rotations[:] = quat
    s.opacities[:] = opacity
    s.sh_dc[:] = (np.asarray(rgbs, np.float64) - 0.5) / C0  # colour = C0 dc + 0.5
    return s


def contour_pixels(item: RenderItem, cam) -> tuple[np.ndarray, np.ndarray]:
    """(inside, margin) per pixel centre for the item's first splat, from its conic:
    inside where o exp(-m2/2) >= 1/255, i.e. m2 <= 2 ln(255 o); margin = |m2 - that|."""
    p = project(item, cam)
    u, v = p.means2d[0]
    a, b, c = p.conic[0]
    ys, xs = np.mgrid[0:cam.height, 0:cam.width] + 0.5
    dx, dy = xs - u, ys - v
    m2 = a * dx * dx + 2.0 * b * dx * dy + c * dy * dy
    limit = 2.0 * np.log(255.0 * p.opacity[0])
    return m2 <= limit, np.abs(m2 - limit)


def ring_pixels(item: RenderItem, cam) -> np.ndarray:
    """Pixel centres inside the contour but outside the 3-sigma square quad."""
    p = project(item, cam)
    u, v = p.means2d[0]
    ys, xs = np.mgrid[0:cam.height, 0:cam.width] + 0.5
    r3 = 3.0 * p.radius[0] / p.extent[0]
    outside = (np.abs(xs - u) > r3) | (np.abs(ys - v) > r3)
    return contour_pixels(item, cam)[0] & outside


# -- the renderers (fixtures: import them into the test module) ----------------------------
PATHS = ["reference", "gl", "gl33", "viewport"]


@pytest.fixture(scope="module")
def gl():
    from addon.gl import OffscreenRenderer

    with OffscreenRenderer() as r:
        yield r


@pytest.fixture(scope="module")
def gl33():
    from addon.gl import OffscreenRenderer

    with OffscreenRenderer(compute=False) as r:
        assert not r.uses_compute
        yield r


@pytest.fixture(scope="module")
def gpu_ready(_bpy_registered):
    from testing.headless import ensure_gpu

    ensure_gpu()
    return True


def render_rgba(path, request, items, cam, options=RenderOptions()) -> np.ndarray:
    """RGBA of items drawn through one renderer: the reference, the moderngl renderer
    (compute shaders), its GL 3.3 fallback, or the viewport's gpu-module draw."""
    if path == "reference":
        return reference.render(items, cam, options).rgba
    if path in ("gl", "gl33"):
        return request.getfixturevalue(path).render(items, cam, options).rgba
    from addon.blender.viewport import DrawSettings, ItemDisplay
    from testing.viewport_scene import draw_offscreen

    request.getfixturevalue("gpu_ready")
    displays = [ItemDisplay(key_bits=options.key_bits)] * len(items)
    return draw_offscreen(items, cam, displays, DrawSettings(capped_extent=options.capped_extent))[0]
