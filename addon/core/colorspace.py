"""sRGB <-> scene-linear, the exact IEC 61966-2-1 piecewise curves (float64 inside).

Captures are display-referred sRGB; Blender's render result and EXRs are
scene-linear (Rec.709 primaries, which sRGB shares, so only the transfer curve
changes). Negative values are mirrored (sign * f(|x|)) so an out-of-gamut
grade round-trips; values above 1 follow the same power law.
"""
from __future__ import annotations

import numpy as np

_A = 0.055
_SRGB_KNEE = 0.04045      # sRGB value where the curve turns linear
_LINEAR_KNEE = 0.0031308  # the same point in linear terms (0.04045 / 12.92)


def srgb_to_linear(c) -> np.ndarray:
    c = np.asarray(c, np.float64)
    x = np.abs(c)
    lin = np.where(x <= _SRGB_KNEE, x / 12.92, ((x + _A) / (1.0 + _A)) ** 2.4)
    return np.copysign(lin, c)


def linear_to_srgb(v) -> np.ndarray:
    v = np.asarray(v, np.float64)
    x = np.abs(v)
    srgb = np.where(x <= _LINEAR_KNEE, x * 12.92, (1.0 + _A) * x ** (1.0 / 2.4) - _A)
    return np.copysign(srgb, v)


def premultiplied_srgb_to_linear(rgba) -> np.ndarray:
    """(..., 4) premultiplied sRGB RGBA -> premultiplied linear RGBA, same dtype.

    The curve applies to the straight colour: divide by alpha, convert, multiply
    back. Where alpha is 0 the (premultiplied) colour is converted directly, so
    additive emission with zero alpha keeps its meaning.
    """
    rgba = np.asarray(rgba)
    out = np.empty(rgba.shape, np.float64)
    a = rgba[..., 3:4].astype(np.float64)
    rgb = rgba[..., :3].astype(np.float64)
    safe = np.where(a > 0, a, 1.0)
    out[..., :3] = srgb_to_linear(rgb / safe) * safe
    out[..., 3:] = a
    return out.astype(rgba.dtype if rgba.dtype.kind == "f" else np.float32)
