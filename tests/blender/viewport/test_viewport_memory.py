"""The viewport's per-splat GPU memory and its once-per-splat preprocess pass (real bpy,
Blender's GPU started headless, drawing into a GPUOffScreen)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from addon.core.camera import look_at, simple_camera
from addon.core.scene import RenderItem
from addon.core.splats import SplatSet
from testing.viewport_scene import blob, draw_offscreen, psnr

# bytes per texel, by the format name a GPUTexture reports
TEXEL_BYTES = {"RGBA32F": 16, "RGBA16F": 8, "R32F": 4, "RGBA16": 8, "RG32F": 8, "R16F": 2}


def _camera(distance=3.0):
    return simple_camera(64, 48, 50.0, look_at((0.0, -distance, 0.4), (0.0, 0.0, 0.0)), near=0.05, far=50.0)


def _bytes(textures) -> int:
    return sum(t.width * t.height * TEXEL_BYTES[t.format] for t in textures)


def test_degree_3_data_takes_at_most_128_bytes_a_splat(gpu_ready):
    """Counted from the textures the renderer uploaded (their size and format as the GPU
    module reports them): splat data and draw order. 16,384 splats fill whole 4096-texel
    rows of every texture, so no padding is counted. Before quantising: 260 bytes."""
    n = 16384
    item = RenderItem(blob(n, 3, seed=3, centre=(0, 0, 0), spread=0.3))
    _, renderer = draw_offscreen([item], _camera())
    gpu = renderer.gpu
    assert set(gpu.textures) == {"pos", "shape", "sh", "order", "objects"}
    data = _bytes(gpu.textures[k] for k in ("pos", "shape", "sh", "order")) / n
    assert data <= 128.0
    # the view records of the preprocess pass: working memory beside the data
    assert _bytes(gpu.records.values()) / n <= 48.0
    assert renderer.stats.drawn > 0.9 * n


def test_a_still_view_preprocesses_once(gpu_ready):
    """The projection runs once per splat per view: redrawing an unchanged view reuses the
    records (and draws the same pixels); a new view or new data makes new ones."""
    from addon.blender.viewport import ViewportRenderer

    item = RenderItem(blob(500, 2, seed=4, centre=(0, 0, 0), spread=0.3), key=("m", 1))
    renderer = ViewportRenderer()
    first, _ = draw_offscreen([item], _camera(), renderer=renderer)
    again, _ = draw_offscreen([item], _camera(), renderer=renderer)
    assert renderer.gpu.preprocesses == 1
    assert psnr(first, again) == float("inf")
    draw_offscreen([item], _camera(2.5), renderer=renderer)
    assert renderer.gpu.preprocesses == 2
    faded = replace(item, splats=replace(item.splats, opacities=item.splats.opacities * np.float32(0.5)))
    draw_offscreen([faded], _camera(2.5), renderer=renderer)
    assert renderer.gpu.preprocesses == 3


def test_undrawable_splats_draw_nothing(gpu_ready):
    """Zero or NaN quaternions, NaN scales and NaN SH (degree 3) are culled, as the
    reference culls them: half floats hold no NaN the same way on every Blender, so
    packing marks such splats in the float32 opacity. The frame equals the one drawn
    without them, bit for bit."""
    good = blob(400, 3, seed=6, centre=(0, 0, 0), spread=0.3)
    bad = good.subset(np.arange(400))
    bad.rotations[0::7] = 0.0
    bad.rotations[1::7] = np.nan
    bad.scales[2::7, 1] = np.nan
    bad.sh_rest[3::7, 14, 2] = np.nan
    bad.sh_dc[4::7, 0] = np.inf
    keep = np.ones(400, bool)
    for start in range(5):
        keep[start::7] = False
    drawn, _ = draw_offscreen([RenderItem(bad)], _camera())
    want, _ = draw_offscreen([RenderItem(good.subset(np.flatnonzero(keep)))], _camera())
    assert want[..., 3].max() > 0.5
    assert psnr(drawn, want) == float("inf")


def test_objects_find_their_rows_in_a_concatenation(gpu_ready):
    """Several objects share the data textures; the preprocess pass finds each splat's
    object (matrix, look, SH degree) by its index. Three objects, degrees 0, 3 and 1,
    placed apart: the drawing matches the reference."""
    from addon.core import reference
    from addon.core.scene import RenderOptions

    items = []
    for k, degree in enumerate((0, 3, 1)):
        world = np.eye(4)
        world[:3, 3] = (0.6 * (k - 1), 0.0, 0.0)
        world[:3, :3] *= 0.5 + 0.25 * k
        items.append(RenderItem(blob(150 + 50 * k, degree, seed=10 + k, centre=(0, 0, 0), spread=0.15), world,
                                opacity_scale=1.0 - 0.2 * k))
    cam = _camera()
    drawn, _ = draw_offscreen(items, cam)
    ref = reference.render(items, cam, RenderOptions()).rgba
    assert ref[..., 3].max() > 0.5
    assert psnr(drawn, ref) >= 60.0


def test_smallest_three_quaternions_round_trip():
    """The shape texture's rotation: the three smallest components and the index of the
    dropped one, carried in the signs of two scales. Decoded as the shader does, each
    rotation matrix is within half-float rounding of the original."""
    from addon.blender.viewport.packing import HALF_TINY, halves, pack_shape
    from addon.core.preprocess import quat_to_matrix

    rng = np.random.default_rng(8)
    s = SplatSet.allocate(1000, 0)
    q = rng.normal(size=(1000, 4))
    q[:10] = np.eye(4)[np.arange(10) % 4] * -2.0  # one component only, negative, unnormalised
    s.rotations[:] = q
    s.scales[:] = rng.uniform(1e-3, 1.0, (1000, 3))
    s.scales[5, 2] = 0.0
    v = pack_shape(s).reshape(-1)[:9000].reshape(1000, 9)
    largest = (v[:, 3] < 0).astype(int) + 2 * (v[:, 4] < 0).astype(int)
    three = v[:, :3].astype(np.float64)
    big = np.sqrt(np.maximum(0.0, 1.0 - (three ** 2).sum(1)))
    decoded = np.insert(three, 0, 0.0, axis=1)
    for i in range(1000):  # insert the largest at its index, as quat_from_three does
        decoded[i] = np.insert(three[i], largest[i], big[i])
    want, _ = quat_to_matrix(q)
    got, _ = quat_to_matrix(decoded)
    assert np.abs(got - want).max() < 2e-3
    assert np.array_equal(np.abs(v[:, 3:6]), np.where(halves(s.scales) == 0, HALF_TINY, halves(s.scales)))
    assert np.array_equal(v[:, 6:9], halves(s.sh_dc))
