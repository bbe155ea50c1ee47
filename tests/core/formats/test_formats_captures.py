"""Every format of the real captures decodes to the same splats, within each format's
quantization step (steps from testdata/SOURCES.md and the format definitions; a float32
rounding allowance EPS is added where a decode does float arithmetic)."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.formats import read, read_with_report
from addon.core.formats.plyheader import read_elements
from addon.core.sh import C0

N_GUITAR = 90854
EPS = 4 * np.finfo(np.float32).eps  # relative float32 slack for a few decode operations


@pytest.fixture(scope="module")
def guitar(testdata):
    return read(testdata / "guitar.ply")


def close(a, b, bound, scale=1.0):
    """|a - b| <= bound + float32 slack relative to the magnitude."""
    slack = EPS * np.maximum(np.abs(a), np.abs(b)) + EPS * scale
    excess = np.abs(a - b) - (bound + slack)
    assert excess.max() <= 0, f"worst excess {excess.max()} over bound"


def rotations_close(a, b, component_bound):
    """q and -q are the same rotation: align signs, then compare per component."""
    sign = np.where(np.einsum("ij,ij->i", a, b) < 0, -1.0, 1.0).astype(np.float32)
    close(a, b * sign[:, None], component_bound)


def test_all_guitar_formats_count(testdata):
    """Every format reads in its own frame: RDF for the PLYs and .splat, RUB for .spz (SPZ's
    documented frame; these splat-transform files hold the PLY's values, so comparing them
    with the PLY takes axes="RDF", as the tests below do)."""
    for name, axes in (("guitar.ply", "RDF"), ("guitar.compressed.ply", "RDF"), ("guitar.splat", "RDF"),
                       ("guitar.spz", "RUB"), ("guitar_v3.spz", "RUB")):
        s, report = read_with_report(testdata / name)
        assert s.count == N_GUITAR and s.sh_degree == 0 and s.axes == axes, name
        assert report.bad.total == 0, (name, report.bad)


def test_compressed_ply_matches(testdata, guitar):
    """Bounds: half a quantization step of each packed field, in the chunk's own range:
    position 11/10/11 bits and log scale 11/10/11 bits over [min, max]; colour 8 bits over
    [min_rgb, max_rgb] then / C0; opacity 8 bits; rotation: three 10-bit components over
    +-sqrt(1/2), half step h, and the derived largest component is off by at most 3h."""
    c = read(testdata / "guitar.compressed.ply")
    path = testdata / "guitar.compressed.ply"
    chunks = read_elements(path)[1]["chunk"]
    owner = np.arange(N_GUITAR) // 256
    levels = np.array([2047, 1023, 2047], np.float64)
    for lo, hi, attr, log in (("min_{}", "max_{}", "positions", False),
                              ("min_scale_{}", "max_scale_{}", "scales", True)):
        span = np.stack([chunks[hi.format(a)] - chunks[lo.format(a)] for a in "xyz"], 1)[owner]
        got, want = getattr(c, attr), getattr(guitar, attr)
        if log:
            got, want = np.log(got), np.log(want)
        close(got, want, 0.5 * span / levels)
    span_rgb = np.stack([chunks[f"max_{a}"] - chunks[f"min_{a}"] for a in "rgb"], 1)[owner]
    close(c.sh_dc, guitar.sh_dc, 0.5 * span_rgb / 255 / C0, scale=1 / C0)
    close(c.opacities, guitar.opacities, 0.5 / 255)
    h = 0.5 * np.sqrt(2) / 1023
    rotations_close(c.rotations, guitar.rotations, 3 * h)


def _match_by_position(a, b):
    """.splat is reordered: sort both by position (stored as float32 in both), check the
    positions then coincide exactly, and return the aligned sets."""
    ka, kb = np.lexsort(a.positions.T), np.lexsort(b.positions.T)
    a, b = a.subset(ka), b.subset(kb)
    np.testing.assert_array_equal(a.positions, b.positions)
    return a, b


def test_splat_matches_as_set(testdata, guitar):
    """convert.py truncates (numpy astype(uint8)) rather than rounds, so colour and alpha
    sit within one full u8 step below the true value, colour after clipping to [0, 1]; each
    rotation byte within one step 1/128, so |e| <= 2/128 and the renormalized quaternion
    within 2|e| = 1/32 per component. Scales are float32 in the file (exp computed in
    float32 by the writer), so within the EPS slack."""
    a, b = _match_by_position(guitar, read(testdata / "guitar.splat"))
    close(a.scales, b.scales, 0.0)
    colour_a = np.clip(0.5 + C0 * a.sh_dc, 0, 1)
    close(colour_a, 0.5 + C0 * b.sh_dc, 1 / 255)
    close(a.opacities, b.opacities, 1 / 255)
    rotations_close(a.rotations, b.rotations, 1 / 32)


@pytest.mark.parametrize("name", ["guitar.spz", "guitar_v3.spz"])
def test_spz_matches(testdata, guitar, name):
    """SPZ steps: positions 12 fractional bits (half step 2^-13); log scale u8 in steps of
    1/16 over [-10, 5.9375] (clipped there); colour u8 of 0.15*dc + 0.5 (clipped to [0, 1]);
    alpha u8; rotation (v3+) three 9-bit magnitudes over sqrt(1/2), half step h, largest
    component within 3h."""
    s = read(testdata / name, axes="RDF")  # splat-transform 3.7 wrote the PLY's frame
    close(s.positions, guitar.positions, 2.0 ** -13)
    close(np.log(s.scales), np.clip(np.log(guitar.scales), -10, 255 / 16 - 10), 1 / 32, scale=10)
    close(0.15 * s.sh_dc + 0.5, np.clip(0.15 * guitar.sh_dc + 0.5, 0, 1), 0.5 / 255)
    close(s.opacities, guitar.opacities, 0.5 / 255)
    rotations_close(s.rotations, guitar.rotations, 3 * 0.5 * np.sqrt(0.5) / 511)


def test_test64_keeps_degree3(testdata):
    """Degree-3 SH survives ply, compressed ply and spz. Compressed sh is uchar over [-4, 4]
    (half step 4/256); spz stores band 1 in steps of 8/128 and bands 2-3 in 16/128 (half
    steps 1/32 and 1/16), clipped to [-1, 127/128]."""
    ply = read(testdata / "test64.ply")
    comp = read(testdata / "test64.compressed.ply")
    spz = read(testdata / "test64.spz", axes="RDF")  # splat-transform 3.7 wrote the PLY's frame
    for s in (ply, comp, spz):
        assert (s.count, s.sh_degree, s.sh_rest.shape) == (64, 3, (64, 15, 3))
    close(comp.sh_rest, ply.sh_rest, 4 / 256, scale=4)
    want = np.clip(ply.sh_rest, -1, 127 / 128)
    close(spz.sh_rest[:, :3], want[:, :3], 1 / 32)
    close(spz.sh_rest[:, 3:], want[:, 3:], 1 / 16)
    assert np.abs(ply.sh_rest[:, 8:]).max() > 0.05  # degree-3 band really carries data


def test_test64_splat_drops_sh(testdata):
    s = read(testdata / "test64.splat")
    assert (s.count, s.sh_degree) == (64, 0)
