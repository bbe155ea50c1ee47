"""What every renderer takes: splat objects placed in the world, a camera, options."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .splats import SplatSet

IDENTITY_COLOR = np.hstack([np.eye(3), np.zeros((3, 1))])


@dataclass
class RenderItem:
    """One splat object, evaluated at one frame (effects already applied to `splats`).

    world          (4, 4) float64 object-to-world matrix (the evaluated one)
    splat_scale    multiplies every splat's scale (the object's size multiplier)
    opacity_scale  multiplies every splat's opacity
    sh_degree      bands above this are ignored (capped by the data's own degree)
    color_matrix   (3, 4) affine applied to the SH colour (after +0.5, before the clamp
                   at 0): tint, exposure, saturation and hue as one linear map
    key            identity for caches: (object name, geometry version); None = no caching
    positions_key  equal non-None keys mean bitwise-equal positions (a renderer may keep its
                   depth sort); None = unknown. Colour/opacity-only changes keep it.
    """

    splats: SplatSet
    world: np.ndarray = field(default_factory=lambda: np.eye(4))
    splat_scale: float = 1.0
    opacity_scale: float = 1.0
    sh_degree: int = 3
    color_matrix: np.ndarray = field(default_factory=lambda: IDENTITY_COLOR.copy())
    key: tuple | None = None
    positions_key: tuple | None = None

    @property
    def effective_sh_degree(self) -> int:
        return max(0, min(self.sh_degree, self.splats.sh_degree))


@dataclass(frozen=True)
class RenderOptions:
    antialiased: bool = False          # gsplat's opacity compensation for the 0.3 px^2 low-pass
    early_termination: bool = False    # stop a pixel at transmittance < 1e-4 (INRIA tile rasterizer)
    capped_extent: bool = False        # quads at min(3, sqrt(2 ln(255 o))) sigma, not the 1/255 contour: faster
    key_bits: int = 32                 # 16 or 32-bit depth sort keys
    gpu_sort: bool = True              # offscreen renderer: compute-shader sort when GL >= 4.3
    background: tuple = (0.0, 0.0, 0.0, 0.0)  # premultiplied sRGB RGBA behind the splats


@dataclass
class RenderOutput:
    """rgba: (H, W, 4) float32, premultiplied, display-referred sRGB, top-down rows.
    depth: (H, W) float32 view-space depth (-z) of the splat at which the pixel's
    accumulated alpha first reaches 0.5, front to back; inf where it never does."""

    rgba: np.ndarray
    depth: np.ndarray
