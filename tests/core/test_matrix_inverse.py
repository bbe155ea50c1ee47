"""matrix_inverse.inverse4 against numpy's LAPACK inverse, and its singular cases."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.effects.common import inverse
from addon.core.matrix_inverse import inverse4


def test_inverse4_matches_numpy_to_the_condition_number():
    rng = np.random.default_rng(0)
    for k in range(500):
        m = rng.normal(size=(4, 4)) if k % 2 else np.eye(4)
        if not k % 2:  # affine transforms of every scale, as objects, gizmos and cameras are
            m[:3, :4] = rng.normal(size=(3, 4)) * rng.uniform(1e-3, 1e3)
        expect = np.linalg.inv(m)
        error = np.abs(inverse4(m) - expect).max() / np.abs(expect).max()
        assert error <= 1e-14 * np.linalg.cond(m)
        np.testing.assert_allclose(inverse4(m) @ m, np.eye(4), atol=1e-9 * np.linalg.cond(m))


def test_singular_raises_as_numpy_does_and_effects_fall_back_to_pinv():
    m = np.diag([2.0, 0.0, 4.0, 1.0])  # an Empty scaled to 0 on an axis
    for invert in (inverse4, np.linalg.inv):
        with pytest.raises(np.linalg.LinAlgError):
            invert(m)
    np.testing.assert_allclose(inverse(m), np.linalg.pinv(m))  # the gizmo still works


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_a_value_that_is_not_finite_gives_what_numpy_gives(value):
    m = np.diag([2.0, 3.0, 4.0, 1.0])
    m[1, 1] = value
    m[0, 3] = 5.0
    with np.errstate(all="ignore"):
        np.testing.assert_array_equal(inverse4(m), np.linalg.inv(m))


def test_inverse4_takes_only_4x4():
    with pytest.raises(ValueError, match="4x4"):
        inverse4(np.eye(3))


def test_inverse_or_pinv_of_a_3x3_is_its_inverse_or_pseudo_inverse():
    """The object-to-camera rotation part (preprocess.camera_in_object) goes through the
    same fallback as gizmo frames: inverse4 of the padded matrix, pinv where singular."""
    from addon.core.matrix_inverse import inverse_or_pinv

    rng = np.random.default_rng(4)
    a = rng.normal(size=(3, 3))
    np.testing.assert_allclose(inverse_or_pinv(a), np.linalg.inv(a), rtol=1e-12, atol=1e-12)
    flat = np.diag([2.0, 0.0, 4.0])  # an object scaled to 0 on an axis
    np.testing.assert_allclose(inverse_or_pinv(flat), np.linalg.pinv(flat), atol=1e-15)


def test_thickened_keeps_every_transform_but_a_flattened_one():
    """Invertible transforms come back bit for bit; one scaled to 0 along an axis keeps FLAT
    of its largest scale there, and moves no point by more than that much of its size."""
    from addon.core.matrix_inverse import FLAT, thickened

    rng = np.random.default_rng(7)
    for _ in range(50):
        m = np.eye(4)
        m[:3, :4] = rng.normal(size=(3, 4))
        assert np.array_equal(thickened(m), m)
    for scale in ((1.0, 0.0, 2.0), (0.0, 0.0, 3.0), (1.0, 1.0, 1e-9)):
        m = np.eye(4)
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        m[:3, :3] = q @ np.diag(scale)
        m[:3, 3] = (1.0, -2.0, 0.5)
        out = thickened(m)
        s = np.linalg.svd(out[:3, :3], compute_uv=False)
        assert s[2] >= FLAT * s[0] * (1 - 1e-9)
        p = rng.normal(size=(100, 3))
        moved = np.linalg.norm(p @ (out[:3, :3] - m[:3, :3]).T, axis=1)
        assert (moved <= 1.01 * FLAT * s[0] * np.linalg.norm(p, axis=1)).all()
        np.testing.assert_array_equal(out[:3, 3], m[:3, 3])
    for m in (np.zeros((4, 4)), np.full((4, 4), np.nan)):
        assert np.array_equal(thickened(m), m, equal_nan=True)  # nothing to keep: as it was
