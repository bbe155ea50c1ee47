"""The moderngl offscreen renderer (addon/gl) pinned to the float64 reference renderer.

Tolerance, and why: both renderers compute the same formulas, one in float32 on the GPU
and one in float64. Rounding alone moves a pixel by ~1e-6 (measured 1.4e-6 on test64,
i.e. ~140 dB). The only larger differences are discrete events: a pixel centre lying
within float32 rounding of a quad edge or of the alpha = 1/255 cut, or two splats
whose depths fall in one sort key (then ordered by index). Each such event changes one
pixel by at most the alpha there (<= 0.99 * exp(-4.5) ~ 0.011 at a 3-sigma edge; one
ordering swap of two splats can change more). A few events in a 160x120 frame keep PSNR
above 70 dB, so 60 dB is the bar: far above any real bug (a wrong sign, a missing
low-pass, a wrong SH band or a wrong blend all cost > 15 dB), and far below rounding.
"""
from __future__ import annotations

import threading

import moderngl
import numpy as np
import pytest

from addon.core import reference
from addon.core.formats import read
from addon.core.scene import RenderItem, RenderOptions
from addon.core.sort import back_to_front, depth_keys
from addon.gl import OffscreenRenderer
from addon.gl.sort import sorts_on_gpu
from testing.gl_scenes import (assert_depth_matches, framing_camera, psnr, random_splats,
                                two_objects, world_for)

MIN_PSNR = 60.0


@pytest.fixture(scope="module")
def test64(testdata):
    s = read(testdata / "test64.ply")
    assert s.sh_degree == 3
    return s


def assert_close(out, ref, min_psnr=MIN_PSNR):
    assert out.rgba.shape == ref.rgba.shape and out.rgba.dtype == np.float32
    assert psnr(out.rgba, ref.rgba) >= min_psnr
    # the alpha must not be trivially empty (a blank image would pass against a blank one)
    assert ref.rgba[..., 3].max() > 0.5


@pytest.mark.parametrize("degree", [0, 1, 2, 3])
def test_test64_each_sh_degree(renderer, test64, degree):
    item = RenderItem(test64, world=world_for(test64), sh_degree=degree, key=("test64", 0))
    cam = framing_camera(item, 128, 96)
    out = renderer.render([item], cam, RenderOptions())
    ref = reference.render([item], cam, RenderOptions())
    assert_close(out, ref)


def test_lower_degrees_read_from_a_degree_three_upload(test64):
    """The rest buffer holds whole groups of four coefficients per splat, sized by what
    was uploaded (15 here): lower degrees must step over the groups they don't read."""
    with OffscreenRenderer() as r:
        for degree in (3, 1, 2):
            item = RenderItem(test64, world=world_for(test64), sh_degree=degree, key=("test64", 3))
            cam = framing_camera(item, 128, 96)
            out = r.render([item], cam, RenderOptions())
            assert_close(out, reference.render([item], cam, RenderOptions()))
        assert r.stats["sh_uploads"] == 1


@pytest.mark.parametrize("options", [
    RenderOptions(),
    RenderOptions(antialiased=True),
    RenderOptions(capped_extent=True),
    RenderOptions(antialiased=True, capped_extent=True),
    RenderOptions(gpu_sort=False),
    RenderOptions(key_bits=16),
    RenderOptions(background=(0.1, 0.2, 0.3, 0.5)),
    RenderOptions(background=(0.0, 0.0, 0.0, 1.0)),
], ids=["default", "aa", "3sigma", "aa-3sigma", "cpu-sort", "16bit", "background", "opaque-film"])
def test_two_objects_against_reference(renderer, options):
    items = two_objects()
    cam = framing_camera(items[0], 160, 120)
    out = renderer.render(items, cam, options)
    ref = reference.render(items, cam, options)
    assert_close(out, ref)
    assert_depth_matches(out, items, cam, options)


def test_settings_change_the_image(renderer, test64):
    """The options are wired through. Antialiasing and the SH degree change the picture.
    The capped extent changes it a little: it drops only the ring between 3 sigma and the
    1/255 contour, where alpha <= 0.99 exp(-4.5) ~ 0.011."""
    item = RenderItem(test64, world=world_for(test64), key=("test64", 0))
    cam = framing_camera(item, 96, 72)
    base = renderer.render([item], cam, RenderOptions()).rgba
    assert psnr(renderer.render([item], cam, RenderOptions(antialiased=True)).rgba, base) < 60.0
    capped = renderer.render([item], cam, RenderOptions(capped_extent=True)).rgba
    assert not np.array_equal(capped, base)
    assert psnr(capped, base) >= 40.0
    item0 = RenderItem(test64, world=world_for(test64), sh_degree=0, key=("test64", 0))
    assert psnr(renderer.render([item0], cam, RenderOptions()).rgba, base) < 60.0


@pytest.mark.parametrize("bits", [16, 32])
def test_gpu_and_cpu_sort_agree_exactly(renderer, bits):
    items = two_objects(4000)
    cam = framing_camera(items[0], 96, 64)
    gpu = renderer.render(items, cam, RenderOptions(key_bits=bits, gpu_sort=True))
    gpu_order = renderer.last_order()
    cpu = renderer.render(items, cam, RenderOptions(key_bits=bits, gpu_sort=False))
    cpu_order = renderer.last_order()
    assert gpu_order.size > 1000
    np.testing.assert_array_equal(gpu_order, cpu_order)
    np.testing.assert_array_equal(gpu.rgba, cpu.rgba)
    np.testing.assert_array_equal(gpu.depth, cpu.depth)


def test_the_default_sort_is_the_cpu_one_on_a_software_gl_and_the_gpu_one_elsewhere(renderer):
    """RenderOptions.gpu_sort=None: numpy sorts where the GL runs on the CPU (as here,
    llvmpipe), the compute passes on a real GPU; either way the same frame."""
    assert not sorts_on_gpu(None, "llvmpipe (LLVM 15.0.6, 256 bits)")
    assert not sorts_on_gpu(None, "Microsoft Basic Render Driver")
    assert sorts_on_gpu(None, "NVIDIA H100 80GB HBM3/PCIe/SSE2")
    assert sorts_on_gpu(True, "llvmpipe") and not sorts_on_gpu(False, "NVIDIA H100")
    items = two_objects(3000)
    cam = framing_camera(items[0], 96, 64)
    software = not sorts_on_gpu(None, renderer.gl_info["GL_RENDERER"])
    before = dict(renderer.stats)
    default = renderer.render(items, cam, RenderOptions())
    sorted_on = "cpu_sorts" if software else "gpu_sorts"
    assert renderer.stats[sorted_on] == before[sorted_on] + 1
    forced = renderer.render(items, cam, RenderOptions(gpu_sort=software))
    np.testing.assert_array_equal(default.rgba, forced.rgba)


def test_gpu_radix_sort_matches_numpy_on_depths(renderer):
    """The GPU order equals core.sort.back_to_front on the renderer's own depths,
    including many equal keys (16 bits over a deep range)."""
    s = random_splats(20000, 0, seed=5, spread=3.0)
    item = RenderItem(s, key=("deep", 0))
    cam = framing_camera(item, 64, 64, distance=0.8)
    renderer.render([item], cam, RenderOptions(key_bits=16))
    depth = renderer.last_depths()
    expect = back_to_front(depth, 16, np.isfinite(depth))
    np.testing.assert_array_equal(renderer.last_order(), expect)
    keys = depth_keys(depth, 16, np.isfinite(depth))[np.isfinite(depth)]
    assert len(np.unique(keys)) < keys.size  # ties exist: stability is exercised


def test_sixteen_bit_keys_cost_little(renderer, test64):
    item = RenderItem(test64, world=world_for(test64))
    cam = framing_camera(item, 128, 96)
    ref = reference.render([item], cam, RenderOptions())
    for bits in (16, 32):
        assert_close(renderer.render([item], cam, RenderOptions(key_bits=bits)), ref)


def test_no_reupload_when_unchanged(renderer, test64):
    stats = renderer.stats
    item = RenderItem(test64, world=world_for(test64), sh_degree=0, key=("cache", 1))
    cam = framing_camera(item, 32, 32)
    renderer.render([item], cam)
    geo, sh, nbytes = stats["geometry_uploads"], stats["sh_uploads"], stats["bytes_uploaded"]
    assert sh == stats["sh_uploads"]
    renderer.render([item], cam)  # same data
    moved = RenderItem(test64, world=world_for(test64, (0.1, 0, 0)), sh_degree=0, key=("cache", 1),
                       opacity_scale=0.5)
    renderer.render([moved], cam)  # transform/opacity change: uniforms only
    assert (stats["geometry_uploads"], stats["sh_uploads"], stats["bytes_uploaded"]) == (geo, sh, nbytes)
    # degree 0 sent no SH; asking for degree 2 sends bands 1..2 once
    item2 = RenderItem(test64, world=world_for(test64), sh_degree=2, key=("cache", 1))
    renderer.render([item2], cam)
    renderer.render([item2], cam)
    assert stats["sh_uploads"] == sh + 1 and stats["geometry_uploads"] == geo
    assert stats["bytes_uploaded"] == nbytes + 64 * 8 * 3 * 4
    # a new geometry version re-uploads; key None always uploads
    renderer.render([RenderItem(test64, key=("cache", 2), sh_degree=0)], cam)
    assert stats["geometry_uploads"] == geo + 1
    for _ in range(3):
        renderer.render([RenderItem(test64, key=None, sh_degree=0)], cam)
        # the uncached object of the frame before is freed; ("cache", 2) left the scene
        assert stats["resident_objects"] == 1
    assert stats["geometry_uploads"] == geo + 4


def test_degree_zero_uploads_no_sh(test64):
    with OffscreenRenderer() as r:
        item = RenderItem(test64, sh_degree=0, key=("d0", 0))
        r.render([item], framing_camera(item, 16, 16))
        assert r.stats["sh_uploads"] == 0
        # one vec4 each: position + opacity, scale, quaternion, DC colour
        assert r.stats["bytes_uploaded"] == 64 * 16 * 4


def test_empty_scene_is_background(renderer):
    cam = framing_camera(RenderItem(random_splats(10)), 24, 16)
    bg = (0.25, 0.5, 0.0, 0.5)
    for items in ([], [RenderItem(random_splats(0))]):
        out = renderer.render(items, cam, RenderOptions(background=bg))
        assert np.array_equal(out.rgba, np.broadcast_to(np.float32(bg), out.rgba.shape))
        assert np.isinf(out.depth).all()


def test_gl_runs_on_its_own_thread_and_leaves_callers_context_alone(test64):
    """A context current on the calling thread (Blender's, in real use) is untouched.

    The stand-in caller runs on a thread of its own: on the main thread its context would
    replace Blender's own, which other tests in this process have made current there."""
    result = {}

    def caller():
        mine = moderngl.create_context(standalone=True, backend="egl")
        try:
            tex = mine.texture((4, 4), 4, dtype="f4")
            fbo = mine.framebuffer(color_attachments=[tex])
            fbo.use()
            fbo.clear(0.25, 0.5, 0.75, 1.0)
            with OffscreenRenderer() as r:
                item = RenderItem(test64, world=world_for(test64))
                cam = framing_camera(item, 32, 32)
                result["out"] = r.render([item], cam)
                t = threading.Thread(target=lambda: result.update(other=r.render([item], cam)))
                t.start()
                t.join()
            # the caller's context still draws and reads back its own framebuffer
            fbo.use()
            result["got"] = np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32)
        finally:
            mine.release()

    thread = threading.Thread(target=caller)
    thread.start()
    thread.join()
    np.testing.assert_array_equal(result["other"].rgba, result["out"].rgba)
    assert np.allclose(result["got"].reshape(4, 4, 4), (0.25, 0.5, 0.75, 1.0))


def test_close_releases_and_refuses_more_work(test64):
    r = OffscreenRenderer()
    item = RenderItem(test64)
    r.render([item], framing_camera(item, 8, 8))
    r.close()
    assert r.closed
    with pytest.raises(RuntimeError):
        r.render([item], framing_camera(item, 8, 8))
    r.close()  # idempotent

