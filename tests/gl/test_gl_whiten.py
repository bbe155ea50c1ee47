"""sl_whiten (shaders/splat_math.glsl): the draw stage interpolates the whitened offset
w = U d (conic = U^T U) and takes |w|^2 as the Gaussian's power d^T conic d. Pinned here
on the renderer's own GL against the float64 quadratic form, on round splats, needles
and offsets out to the edge of a 4096-pixel tile; and a frame whose quads the clipper
cuts, against the reference."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core import reference
from addon.core.camera import equirect_camera, look_at, simple_camera
from addon.core.scene import RenderItem, RenderOptions
from addon.core.splats import SplatSet
from addon.gl import shaders
from testing.gl_scenes import psnr

EPS = np.finfo(np.float32).eps
PROBE = """
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer In { vec4 rows[]; };  // dx, dy, unused, unused
layout(std430, binding = 1) readonly buffer Conics { vec4 conics[]; };  // A, B, C, opacity
layout(std430, binding = 2) writeonly buffer Out { vec4 result[]; };  // w, alpha, unused
uniform uint u_count;
void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    vec2 w = sl_whiten(rows[i].xy, conics[i].xyz);
    result[i] = vec4(w, sl_alpha_whitened(w, conics[i].w), 0.0);
}
"""


@pytest.fixture(scope="module")
def run_probe(renderer):
    r = renderer
    if not r.uses_compute:
        pytest.skip("needs GL 4.3 compute shaders")
    ctx = r._worker.ctx
    cs = r._worker.call(ctx.compute_shader, "#version 430\n" + shaders.read(shaders.MATH) + PROBE)

    def probe(d: np.ndarray, conic: np.ndarray, opacity: np.ndarray) -> np.ndarray:
        n = len(d)
        rows = np.zeros((n, 4), np.float32)
        rows[:, :2] = d
        cons = np.column_stack([conic, opacity]).astype(np.float32)

        def go():
            bufs = [ctx.buffer(rows.tobytes()), ctx.buffer(cons.tobytes()), ctx.buffer(reserve=16 * n)]
            for binding, buf in enumerate(bufs):
                buf.bind_to_storage_buffer(binding)
            cs["u_count"] = n
            cs.run((n + 63) // 64)
            out = np.frombuffer(bufs[2].read(), np.float32).reshape(n, 4).copy()
            for buf in bufs:
                buf.release()
            return out
        return r._worker.call(go)

    yield probe
    r._worker.call(cs.release)


def conics(rng, n: int, max_aspect: float) -> np.ndarray:
    """Conics of screen ellipses (the low-pass included: axes >= 0.3 px^2 variance) with
    sigma from 0.55 px to 1000 px and long/short axis ratios up to max_aspect."""
    short = np.sqrt(0.3 + 10 ** rng.uniform(-2, 4, n))
    long = short * 10 ** rng.uniform(0, np.log10(max_aspect), n)
    theta = rng.uniform(0, np.pi, n)
    c, s = np.cos(theta), np.sin(theta)
    # covariance R diag(long^2, short^2) R^T, then its inverse
    a = c * c * long ** 2 + s * s * short ** 2
    b = c * s * (long ** 2 - short ** 2)
    d = s * s * long ** 2 + c * c * short ** 2
    det = a * d - b * b
    return np.column_stack([d / det, -b / det, a / det])


@pytest.mark.parametrize("max_aspect", [1.0, 30.0, 3000.0])
def test_whitened_power_is_the_conics_quadratic_form(run_probe, max_aspect):
    rng = np.random.default_rng(int(max_aspect))
    n = 20000
    q = conics(rng, n, max_aspect).astype(np.float32).astype(np.float64)
    # offsets out to 4 sigma along the long axis, or to a 4096-pixel tile's corner
    reach = np.minimum(4.0 / np.sqrt(np.minimum(q[:, 0], q[:, 2])), 5800.0)
    d = (rng.uniform(-1, 1, (n, 2)) * reach[:, None]).astype(np.float32).astype(np.float64)
    out = run_probe(d, q, np.full(n, 0.8))
    a, b, c = q.T
    power = a * d[:, 0] ** 2 + 2 * b * d[:, 0] * d[:, 1] + c * d[:, 1] ** 2
    got = (out[:, :2].astype(np.float64) ** 2).sum(axis=1)
    # float32 error of U d: a few eps of the form's absolute terms, and for the second
    # row the Schur complement's relative error eps A C / det on its share of the power
    terms = a * d[:, 0] ** 2 + 2 * np.abs(b * d[:, 0] * d[:, 1]) + c * d[:, 1] ** 2
    schur = c - b * b / a
    condition = a * c / (a * c - b * b)
    bound = 8 * EPS * (terms + condition * schur * d[:, 1] ** 2)
    err = np.abs(got - power)
    assert np.all(err <= bound), f"worst error {np.max(err / bound):.2f} of its bound"
    assert np.max(err / bound) > 1e-3  # the bound is not vacuous


def test_whitened_alpha_is_sl_alpha(run_probe):
    """sl_alpha_whitened(U d) = min(0.99, o exp(-power / 2)) where the fragments count."""
    rng = np.random.default_rng(7)
    n = 20000
    q = conics(rng, n, 30.0)
    d = rng.normal(size=(n, 2)) * 2.0 / np.sqrt(q[:, [0, 2]])
    opacity = rng.uniform(0.004, 1.0, n)
    out = run_probe(d, q, opacity)
    a, b, c = q.T
    power = a * d[:, 0] ** 2 + 2 * b * d[:, 0] * d[:, 1] + c * d[:, 1] ** 2
    want = np.minimum(0.99, opacity * np.exp(-0.5 * power))
    keep = want >= 1 / 255
    assert keep.sum() > n // 4
    # the power's error (bounded above) moves alpha by alpha * error / 2
    assert np.allclose(out[keep, 2], want[keep], rtol=1e-5, atol=1e-7)


def test_a_long_quad_cut_by_the_clipper_keeps_its_footprint(renderer):
    """A needle right under an equirect camera, half a degree off the pole: its footprint
    is thousands of pixels long and crosses the frame's edges (with its seam copies). The
    draw stage keeps every quad inside the tile, so the rasteriser's clipper cuts none:
    Mesa 22.3's llvmpipe interpolates "noperspective" outputs wrongly on the triangles it
    cuts (0.18 off on these rows when the rectangles crossed the edge)."""
    s = SplatSet.allocate(1, 0)
    s.positions[:] = (-0.01867238, 0.002100088, -1.6)
    s.scales[:] = (0.025542019, 0.024981562, 0.001)
    s.rotations[:] = (0.3248081, 0.7876016, -0.091657266, 0.5155409)
    s.opacities[:] = 0.83793247
    s.sh_dc[:] = (0.25513434, 1.5522686, 0.30066663)
    item = RenderItem(s, key=("pole needle",))
    width, height, rows = 1920, 1080, 67
    camera = equirect_camera(look_at((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)), width, height)
    options = RenderOptions(early_termination=False)
    got = renderer.render([item], camera, options).rgba[height - rows:]
    want = reference.render([item], camera, options, window=(0, height - rows, width, rows)).rgba
    assert (want[..., 3] > 0.1).mean() > 0.03
    assert psnr(got, want) >= 60.0


def test_sharp_needles_far_from_the_origin_keep_their_accuracy(renderer):
    """The interpolated offset's float32 rounding grows with a splat's sharpness and its
    distance from the frame's origin (the rasteriser's plane equations start there): 3,000
    needles 0.1-0.5 px wide over a 1080p frame, checked on its far corner. Measured 98.6 dB
    (101.8 dB when the fragment stage evaluated the quadratic form itself); the bar leaves
    3.6 dB for other GLs' rounding."""
    width, height = 1920, 1080
    camera = simple_camera(width, height, 60.0, np.eye(4), near=0.1, far=100.0)
    focal, depth, n = (width / 2) / np.tan(np.radians(30.0)), 3.0, 3000
    rng = np.random.default_rng(11)
    s = SplatSet.allocate(n, 0)
    u, v = rng.uniform(0, width, n), rng.uniform(0, height, n)
    s.positions[:] = np.column_stack([(u - width / 2) * depth / focal,
                                      (height / 2 - v) * depth / focal, np.full(n, -depth)])
    s.scales[:] = np.column_stack([rng.uniform(3, 30, n), rng.uniform(0.1, 0.5, n),
                                   np.full(n, 0.01)]) * depth / focal
    half = rng.uniform(0, np.pi, n) / 2
    s.rotations[:] = np.column_stack([np.cos(half), np.zeros(n), np.zeros(n), np.sin(half)])
    s.opacities[:] = rng.uniform(0.3, 0.99, n)
    s.sh_dc[:] = rng.normal(0.0, 1.0, (n, 3))
    item = RenderItem(s, key=("sharp needles",))
    options = RenderOptions(early_termination=False)
    got = renderer.render([item], camera, options).rgba[700:, 1400:]
    want = reference.render([item], camera, options, window=(1400, 700, 520, 380)).rgba
    assert (want[..., 3] > 0.1).mean() > 0.1
    assert psnr(got, want) >= 95.0
