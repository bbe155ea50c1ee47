"""Depth of field (core/dof.py): the thin lens as circle-of-confusion widening, checked
against the lens it models: renders averaged over many points of the aperture disk
(each the exact pinhole render from that lens point, dof.lens_camera)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from addon.core import dof, reference
from addon.core.camera import look_at, simple_camera
from addon.core.scene import RenderItem, RenderOptions
from addon.core.splats import SplatSet
from addon.gl import OffscreenRenderer
from testing.gl_scenes import psnr, random_splats

W, H = 96, 72
FOCUS = 6.0


def _camera(defocus=None):
    cam = simple_camera(W, H, 50.0, look_at((0.0, -FOCUS, 0.0), (0.0, 0.0, 0.0)))
    return dataclasses.replace(cam, defocus=defocus)


def _one_splat(y: float, scale: float = 0.02, opacity: float = 0.2) -> RenderItem:
    """A faint round splat on the view axis at depth FOCUS + y (faint: alpha stays
    proportional to the Gaussian, nowhere near the 0.99 cap)."""
    s = SplatSet.allocate(1, 0)
    s.positions[:] = (0.0, y, 0.0)
    s.scales[:] = scale
    s.rotations[:] = (1.0, 0.0, 0.0, 0.0)
    s.opacities[:] = opacity
    s.sh_dc[:] = 1.0
    return RenderItem(s)


def _moments(alpha: np.ndarray):
    """Total, mean (u, v) and variance (u, v) of an alpha image, pixel centres at +0.5."""
    v, u = np.mgrid[0:alpha.shape[0], 0:alpha.shape[1]] + 0.5
    w = alpha.astype(np.float64)
    total = w.sum()
    mu = np.array([(w * u).sum(), (w * v).sum()]) / total
    var = np.array([(w * (u - mu[0]) ** 2).sum(), (w * (v - mu[1]) ** 2).sum()]) / total
    return total, mu, var


def test_fstop_gives_cycles_aperture():
    d = dof.from_fstop(50.0, 2.8, 4.0)
    assert d.aperture_radius == pytest.approx(0.050 / (2 * 2.8)) and d.focus_distance == 4.0
    with pytest.raises(ValueError, match="f-stop"):
        dof.from_fstop(50.0, 0.0, 4.0)


def test_lens_camera_keeps_the_focus_plane_and_shifts_the_rest():
    cam = _camera(dof.Defocus(0.1, FOCUS))
    moved = dof.lens_camera(cam, (0.6, -0.8))
    points = np.array([[0.3, 0.0, 0.2], [0.5, 4.0, -0.3], [-0.2, -2.0, 0.1]])  # depths 6, 10, 4
    shift = moved.project(points)[:, :2] - cam.project(points)[:, :2]
    np.testing.assert_allclose(shift[0], 0.0, atol=1e-9)
    for k, depth in ((1, 10.0), (2, 4.0)):
        want = -np.array([cam.fx * 0.06, -cam.fy * -0.08]) * (1 / depth - 1 / FOCUS)
        np.testing.assert_allclose(shift[k], want, rtol=1e-9)


def test_focus_plane_stays_sharp():
    """A splat at the focus distance renders bit for bit as without depth of field."""
    item = _one_splat(0.0, scale=0.05, opacity=0.9)
    for aa in (False, True):
        options = RenderOptions(antialiased=aa)
        sharp = reference.render([item], _camera(), options).rgba
        focused = reference.render([item], _camera(dof.Defocus(0.2, FOCUS)), options).rgba
        np.testing.assert_array_equal(focused, sharp)


def _untruncated(total, var, opacity):
    """Energy and variance of the whole Gaussian from those of its rendered footprint:
    the renderer cuts at alpha = 1/255, the Mahalanobis radius R^2 = 2 ln(255 o), inside
    which a 2D Gaussian keeps 1 - e^(-R^2/2) of its mass and, per axis, that minus
    R^2/2 e^(-R^2/2) of its variance."""
    tail = 1.0 / (255.0 * opacity)  # e^(-R^2/2)
    kept = 1.0 - tail
    return total / kept, var * kept / (kept - np.log(255.0 * opacity) * tail)


@pytest.mark.parametrize("y", [-2.0, 3.0, 8.0])
def test_out_of_focus_splat_widens_as_the_thin_lens_predicts(y):
    """Its spread, measured on the image, grows by coc^2 / 4 per axis (the variance of a
    uniform disk of radius coc), and its energy stays."""
    from addon.core.preprocess import project

    item, lens = _one_splat(y, scale=0.05, opacity=0.9), dof.Defocus(1.0, FOCUS)
    sharp = reference.render([item], _camera()).rgba[..., 3]
    blurred = reference.render([item], _camera(lens)).rgba[..., 3]
    coc = float(dof.coc_radius(np.array([FOCUS + y]), lens, _camera().fx)[0])
    assert coc > 3.0  # a blur worth measuring, well inside the frame
    o_blurred = float(project(item, _camera(lens)).opacity[0])
    e0, mu0, var0 = _moments(sharp)
    e1, mu1, var1 = _moments(blurred)
    e0, var0 = _untruncated(e0, var0, 0.9)
    e1, var1 = _untruncated(e1, var1, o_blurred)
    np.testing.assert_allclose(mu1, mu0, atol=1e-6)
    np.testing.assert_allclose(var1 - var0, coc * coc / 4.0, rtol=0.02)
    assert e1 == pytest.approx(e0, rel=0.01)


def test_aperture_average_spreads_a_splat_by_the_lens_offsets():
    """The many-sample reference itself: averaging lens_camera renders convolves the
    splat with the lens points' image offsets, so its variance grows by exactly
    coc^2 * mean(p_u^2) (the points' second moment; 1/4 for the full disk)."""
    item, lens = _one_splat(3.0, scale=0.05, opacity=0.9), dof.Defocus(1.0, FOCUS)
    points = dof.lens_samples(256)
    coc = float(dof.coc_radius(np.array([FOCUS + 3.0]), lens, _camera().fx)[0])
    sharp = reference.render([item], _camera()).rgba[..., 3]
    averaged = np.mean([reference.render([item], dof.lens_camera(_camera(lens), p)).rgba[..., 3]
                        for p in points], axis=0)
    e0, _, var0 = _moments(sharp)
    e2, _, var2 = _moments(averaged)
    np.testing.assert_allclose(var2 - var0, coc * coc * (points ** 2).mean(0), rtol=0.01)
    assert e2 == pytest.approx(e0, rel=1e-3)


def test_scene_is_much_nearer_the_aperture_reference_than_the_pinhole():
    """A 1500-splat cloud, 64 lens samples: CoC widening vs the aperture-sampled image
    (measured 46.9 dB at this lens, pinhole 31.9 dB; 256 samples change it < 0.1 dB)."""
    item = RenderItem(random_splats(1500, 1, seed=3, spread=2.0))
    cam = dataclasses.replace(simple_camera(120, 90, 50, look_at((0, -7, 1), (0, 0, 0))),
                              defocus=dof.Defocus(0.1, 5.0))
    lens = np.mean([reference.render([item], dof.lens_camera(cam, p)).rgba
                    for p in dof.lens_samples(64)], axis=0)
    widened = reference.render([item], cam).rgba
    pinhole = reference.render([item], dataclasses.replace(cam, defocus=None)).rgba
    assert psnr(widened, lens) >= 45.0
    assert psnr(widened, lens) >= psnr(pinhole, lens) + 12.0


def test_lens_samples_cover_the_disk_evenly():
    p = dof.lens_samples(64)
    np.testing.assert_array_equal(p, dof.lens_samples(64))  # no randomness
    assert np.all(np.hypot(*p.T) < 1.0)
    np.testing.assert_allclose(p.mean(0), 0.0, atol=0.02)
    np.testing.assert_allclose((p ** 2).mean(0), 0.25, rtol=0.05)  # a uniform disk's variance


def test_dof_needs_a_perspective_camera():
    with pytest.raises(ValueError, match="perspective"):
        dataclasses.replace(_camera(), ortho=True, defocus=dof.Defocus(0.1, 5.0))


@pytest.mark.parametrize("compute", [None, False])
@pytest.mark.parametrize("aa", [False, True])
def test_gl_matches_reference_with_dof(compute, aa):
    """Bar as tests/gl/test_gl_render.py (60 dB): float32 vs float64 of the same formulas."""
    item = RenderItem(random_splats(1500, 2, seed=4, spread=2.0))
    cam = dataclasses.replace(simple_camera(120, 90, 50, look_at((0, -7, 1), (0, 0, 0))),
                              defocus=dof.Defocus(0.1, 5.0))
    options = RenderOptions(antialiased=aa)
    ref = reference.render([item], cam, options).rgba
    with OffscreenRenderer(compute=compute) as r:
        out = r.render([item], cam, options).rgba
        sharp = r.render([item], dataclasses.replace(cam, defocus=None), options).rgba
    assert psnr(out, ref) >= 60.0
    assert psnr(sharp, ref) < 40.0  # the GL frame is blurred, not merely close
