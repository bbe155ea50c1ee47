"""Object-level look: a colour matrix for the renderers, and crop shapes as per-splat opacity.

Colour: the renderers apply RenderItem.color_matrix M (3x4) to the SH colour c (display-
referred sRGB, after the +0.5, before the clamp at 0): c' = M[:, :3] c + M[:, 3]. Here
    M = 2^exposure * diag(tint) * S(saturation) * H(hue)
- H(hue) rotates the chroma of c about the grey axis while keeping its Rec.709 luma
  Y = w.c: c = Y 1 + u with u in the plane w.u = 0; u turns by `hue` radians in an
  orthonormal basis of that plane. H(a) H(b) = H(a + b) and H(2 pi) = I.
- S(s) = (1 - s) 1 w^T + s I scales the chroma about the same luma: s = 0 is grey
  with the same luma, s = 1 is unchanged, s > 1 boosts.
- exposure is in stops on the display-referred value (x 2^e); tint multiplies per channel.
All linear, so a look-only change touches no per-splat data.

Crop: box (centre, full size) and sphere (centre, radius) in object (data) space. The weight
is 1 inside, 0 outside, with a smoothstep over `softness` object units just inside the
boundary; `invert` keeps the outside instead. The renderers see it as opacity.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, replace

import numpy as np

from .splats import SplatSet

LUMA = np.array([0.2126, 0.7152, 0.0722])  # Rec.709 / sRGB primaries


@dataclass(frozen=True)
class CropBox:
    center: tuple = (0.0, 0.0, 0.0)
    size: tuple = (2.0, 2.0, 2.0)
    softness: float = 0.0
    invert: bool = False


@dataclass(frozen=True)
class CropSphere:
    center: tuple = (0.0, 0.0, 0.0)
    radius: float = 1.0
    softness: float = 0.0
    invert: bool = False


def _chroma_basis() -> np.ndarray:
    """(3, 2) orthonormal basis of the plane w.u = 0, oriented so that a positive hue
    turns red towards yellow/green (as Blender's hue does)."""
    e1 = np.cross(LUMA, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(LUMA / np.linalg.norm(LUMA), e1)
    e2 /= np.linalg.norm(e2)
    return np.stack([e1, e2], axis=1)


_GREY = np.outer(np.ones(3), LUMA)    # c -> Y 1
_CHROMA = np.eye(3) - _GREY            # c -> u
_BASIS = _chroma_basis()


def hue_matrix(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    turn = np.array([[c, -s], [s, c]])
    return _GREY + _BASIS @ turn @ _BASIS.T @ _CHROMA


def saturation_matrix(s: float) -> np.ndarray:
    return (1.0 - s) * _GREY + s * np.eye(3)


def color_matrix(tint=(1.0, 1.0, 1.0), exposure: float = 0.0, saturation: float = 1.0,
                 hue: float = 0.0) -> np.ndarray:
    """The (3, 4) matrix; a fresh copy (callers may keep or modify it)."""
    return _color_matrix(tuple(float(t) for t in tint), float(exposure), float(saturation),
                         float(hue)).copy()


@functools.lru_cache(maxsize=64)
def _color_matrix(tint, exposure, saturation, hue) -> np.ndarray:
    if tint == (1.0, 1.0, 1.0) and exposure == 0.0 and saturation == 1.0 and hue == 0.0:
        return np.hstack([np.eye(3), np.zeros((3, 1))])  # exactly the identity
    linear = (2.0 ** exposure) * np.diag(np.asarray(tint, np.float64))
    linear = linear @ saturation_matrix(saturation) @ hue_matrix(hue)
    return np.hstack([linear, np.zeros((3, 1))])


def _inside_weight(distance: np.ndarray, softness: float, invert: bool) -> np.ndarray:
    """distance: signed, negative inside. Weight 1 at depth >= softness, 0 outside."""
    if softness <= 0.0:
        w = (distance < 0.0).astype(np.float32)
    else:
        w = distance * np.float32(-1.0 / softness)
        np.clip(w, 0.0, 1.0, out=w)
        w *= w * (np.float32(3.0) - np.float32(2.0) * w)
    if invert:
        w -= np.float32(1.0)
        w *= np.float32(-1.0)
    return w


def box_distance(positions: np.ndarray, box: CropBox) -> np.ndarray:
    """Signed distance to the box surface (negative inside), column by column."""
    q = [np.abs(positions[:, i] - np.float32(box.center[i])) - np.float32(box.size[i] / 2)
         for i in range(3)]
    inside = np.maximum(np.maximum(q[0], q[1]), q[2])
    np.minimum(inside, 0.0, out=inside)
    outside = np.zeros_like(inside)
    for c in q:
        np.maximum(c, 0.0, out=c)
        c *= c
        outside += c
    np.sqrt(outside, out=outside)
    outside += inside
    return outside


def sphere_distance(positions: np.ndarray, sphere: CropSphere) -> np.ndarray:
    d = np.zeros(positions.shape[0], np.float32)
    for i in range(3):
        c = positions[:, i] - np.float32(sphere.center[i])
        c *= c
        d += c
    np.sqrt(d, out=d)
    d -= np.float32(sphere.radius)
    return d


def crop_weights(positions: np.ndarray, box: CropBox | None = None,
                 sphere: CropSphere | None = None) -> np.ndarray | None:
    """(N,) float32 opacity factors, or None when no crop is enabled."""
    weight = None
    if box is not None:
        weight = _inside_weight(box_distance(positions, box), box.softness, box.invert)
    if sphere is not None:
        w = _inside_weight(sphere_distance(positions, sphere), sphere.softness, sphere.invert)
        weight = w if weight is None else weight * w
    return weight


def apply_crop(splats: SplatSet, box: CropBox | None = None,
               sphere: CropSphere | None = None) -> SplatSet:
    """The splats with crop folded into their opacities (positions array shared)."""
    weight = crop_weights(splats.positions, box, sphere)
    if weight is None:
        return splats
    return replace(splats, opacities=splats.opacities * weight)
