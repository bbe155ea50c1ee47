"""The offscreen renderer's GL 3.3 fallback (no compute shaders: CPU preprocess with
core/preprocess.py and CPU sort, GPU draw), forced with compute=False on the same context.
Same PSNR bar as test_gl_render.py (its docstring explains it)."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core import reference
from addon.core.scene import RenderItem, RenderOptions
from addon.gl import OffscreenRenderer
from testing.gl_scenes import (assert_depth_matches, framing_camera, psnr, random_splats,
                                two_objects, world_for)

MIN_PSNR = 60.0  # as test_gl_render.py


@pytest.fixture(scope="module")
def fallback():
    r = OffscreenRenderer(compute=False)
    assert not r.uses_compute
    yield r
    r.close()


@pytest.mark.parametrize("options", [
    RenderOptions(), RenderOptions(antialiased=True), RenderOptions(key_bits=16),
    RenderOptions(capped_extent=True, background=(0.2, 0.1, 0.0, 0.3)),
], ids=["default", "aa", "16bit", "3sigma-bg"])
def test_fallback_against_reference(fallback, options):
    items = two_objects()
    cam = framing_camera(items[0], 128, 96)
    out = fallback.render(items, cam, options)
    ref = reference.render(items, cam, options)
    assert psnr(out.rgba, ref.rgba) >= MIN_PSNR and ref.rgba[..., 3].max() > 0.5
    assert_depth_matches(out, items, cam, options)


def test_fallback_matches_compute_path(fallback):
    items = [RenderItem(random_splats(2000, 2, seed=3), sh_degree=2)]
    cam = framing_camera(items[0], 96, 64)
    with OffscreenRenderer() as compute:
        assert compute.uses_compute
        a = compute.render(items, cam).rgba
    b = fallback.render(items, cam).rgba
    assert psnr(a, b) >= MIN_PSNR


def test_fallback_empty_and_culled(fallback):
    cam = framing_camera(RenderItem(random_splats(10)), 16, 16)
    out = fallback.render([], cam)
    assert not out.rgba.any() and np.isinf(out.depth).all()
    s = random_splats(50)
    s.rotations[:] = np.nan
    out = fallback.render([RenderItem(s, world=world_for(s))], cam)
    assert not out.rgba.any()


def test_frames_past_the_storage_limit_fall_back_by_themselves(fallback, caplog):
    """A frame with more splats than one storage block holds (~8.4M at 128 MiB; forced
    here to 1000) renders on the GL 3.3 path, said once in the log; smaller frames stay
    on the compute path."""
    big = [RenderItem(random_splats(1500, 1, seed=5), sh_degree=1),
           RenderItem(random_splats(700, 1, seed=6), sh_degree=1)]
    cam = framing_camera(big[0], 64, 48)
    small = big[1:]
    want = fallback.render(big, cam).rgba
    ref = reference.render(big, cam, RenderOptions()).rgba
    with OffscreenRenderer() as r:
        r._worker.call(lambda: setattr(r._state.cache, "max_block", 16 * 1000))
        with caplog.at_level("WARNING"):
            first = r.render(big, cam).rgba
            second = r.render(big, cam).rgba
            r.render(small, cam, RenderOptions(gpu_sort=True))
        assert r.uses_compute and r.stats["gpu_sorts"] >= 1
        assert len(r.last_order()) > 0  # the small frame came back to the compute path
    assert np.array_equal(first, want) and np.array_equal(second, want)
    assert psnr(first, ref) >= MIN_PSNR
    said = [rec.getMessage() for rec in caplog.records if "storage blocks" in rec.getMessage()]
    assert len(said) == 1 and "2,200" in said[0] and "GL 3.3" in said[0]
