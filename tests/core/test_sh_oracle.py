"""SH degrees 2 and 3 checked against values computed independently of addon.core.sh:
explicit polynomials with constants from their closed forms (not copied from INRIA's
table), orthonormality on the sphere, and the oracle's own term-by-term INRIA code
(testing/reference_oracle.py), on a few directions."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.sh import sh_basis, sh_to_rgb
from testing.reference_oracle import SH_C2, SH_C3, sh_rgb

PI = np.pi
DIRS = np.array([(0, 0, 1), (1, 0, 0), (0, -1, 0), (1, 2, 3), (-0.3, 0.8, -0.5), (2, -1, 0.25)], float)
DIRS /= np.linalg.norm(DIRS, axis=1, keepdims=True)


def band2(x, y, z):
    """The five degree-2 functions in INRIA's order and signs, closed-form constants."""
    a, b = np.sqrt(15 / PI) / 2, np.sqrt(5 / PI) / 4
    return [a * x * y, -a * y * z, b * (2 * z * z - x * x - y * y), -a * x * z, a / 2 * (x * x - y * y)]


def band3(x, y, z):
    c0, c1 = np.sqrt(35 / (2 * PI)) / 4, np.sqrt(105 / PI) / 2
    c2, c3 = np.sqrt(21 / (2 * PI)) / 4, np.sqrt(7 / PI) / 4
    return [-c0 * y * (3 * x * x - y * y), c1 * x * y * z, -c2 * y * (4 * z * z - x * x - y * y),
            c3 * z * (2 * z * z - 3 * x * x - 3 * y * y), -c2 * x * (4 * z * z - x * x - y * y),
            c1 / 2 * z * (x * x - y * y), -c0 * x * (x * x - 3 * y * y)]


def test_constants_match_closed_forms():
    """INRIA's table (as the oracle copies it) is sqrt((2l+1)/4pi * (l-|m|)!/(l+|m|)!) times
    the Legendre factors, with INRIA's signs."""
    s15, s5 = np.sqrt(15 / PI), np.sqrt(5 / PI)
    np.testing.assert_allclose(SH_C2, [s15 / 2, -s15 / 2, s5 / 4, -s15 / 2, s15 / 4], rtol=1e-15)
    c0, c1, c2, c3 = (np.sqrt(35 / (2 * PI)) / 4, np.sqrt(105 / PI) / 2, np.sqrt(21 / (2 * PI)) / 4,
                      np.sqrt(7 / PI) / 4)
    np.testing.assert_allclose(SH_C3, [-c0, c1, -c2, c3, -c2, c1 / 2, -c0], rtol=1e-15)


def test_closed_forms_are_orthonormal():
    """Gauss-Legendre in cos(theta) x uniform phi integrates these degree <= 6 products
    exactly: the Gram matrix of bands 2 and 3 must be the identity."""
    t, w = np.polynomial.legendre.leggauss(8)
    phi = np.arange(16) * (2 * PI / 16)
    ct, ph = np.meshgrid(t, phi, indexing="ij")
    st = np.sqrt(1 - ct * ct)
    x, y, z = st * np.cos(ph), st * np.sin(ph), ct
    f = np.stack([v.ravel() for v in band2(x, y, z) + band3(x, y, z)])
    weights = (np.repeat(w, 16) * (2 * PI / 16))
    np.testing.assert_allclose((f * weights) @ f.T, np.eye(12), atol=1e-13)


@pytest.mark.parametrize("degree", [2, 3])
def test_basis_matches_explicit_polynomials(degree):
    basis = sh_basis(DIRS, degree)
    for d, row in zip(DIRS, basis):
        expect = band2(*d) + (band3(*d) if degree == 3 else [])
        np.testing.assert_allclose(row[4:], expect, rtol=1e-14, atol=1e-15)


@pytest.mark.parametrize("degree", [0, 1, 2, 3])
def test_sh_to_rgb_matches_the_oracle(degree):
    rng = np.random.default_rng(degree)
    k = (degree + 1) ** 2 - 1
    dc = rng.normal(size=(len(DIRS), 3))
    rest = rng.normal(0, 0.3, (len(DIRS), 15, 3))
    got = sh_to_rgb(dc, rest, DIRS, degree)
    for i, d in enumerate(DIRS):
        np.testing.assert_allclose(got[i], sh_rgb(dc[i], rest[i, :k], d, degree).astype(float),
                                   rtol=1e-13, atol=1e-14)


def test_one_coefficient_at_a_time():
    """A unit coefficient on one degree-2/3 function gives exactly that function's value."""
    d = DIRS[3]
    expect = band2(*d) + band3(*d)
    for j in range(12):
        rest = np.zeros((15, 3))
        rest[3 + j] = 1.0
        value = sh_to_rgb(np.zeros((1, 3)), rest[None], d[None], 3)[0] - 0.5
        np.testing.assert_allclose(value, expect[j], rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(float(sh_rgb(np.zeros(3), rest, d, 3)[0]) - 0.5, expect[j],
                                   rtol=1e-14, atol=1e-15)
