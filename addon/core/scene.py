"""What every renderer takes: splat objects placed in the world, a camera, options."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .holdout import Holdout
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
    key            identity for caches: (object name, geometry version); None = no caching.
                   Instances of one object share its key (equal keys mean equal splats), so
                   a renderer uploads their splats once
    instance       which copy of the object this is: () for the object itself, else its
                   instance path (instancer's name, persistent id); (key[0], instance) is
                   unique in a frame's items
    positions_key  equal non-None keys mean bitwise-equal positions (a renderer may keep its
                   depth sort); None = unknown. Colour/opacity-only changes keep it.
    base_key       the version of the data before effects and crop; None = unknown
    base_fields    the SplatSet fields that are that data's own arrays, untouched, or
                   read-only arrays (a deferred morph's ends): under an equal base_key the
                   very same array holds the same values, so a renderer may keep what it
                   uploaded of them while `key` changes with the effects
    deferred       colour effects, a last morph and a displace left out of `splats` for the
                   renderer to apply itself (effects.deferral.Deferred, in order; a morph's
                   ends are `splats` and its target, in order, with the centres blended in
                   `splats` already; a displace's centres are moved in `splats` already, to
                   sort by, and the renderer moves them itself from its Deferred.centres,
                   the stack's input); only the viewport asks for them
    rest_positions the effects' input centres, which an `at_rest` deferred effect measures
    lighting       Look > Lighting left to the renderer to apply to `splats` (0: none, or
                   applied already); only the viewport asks for it, lighting in its shader
    """

    splats: SplatSet
    world: np.ndarray = field(default_factory=lambda: np.eye(4))
    splat_scale: float = 1.0
    opacity_scale: float = 1.0
    sh_degree: int = 3
    color_matrix: np.ndarray = field(default_factory=lambda: IDENTITY_COLOR.copy())
    key: tuple | None = None
    positions_key: tuple | None = None
    base_key: tuple | None = None
    base_fields: frozenset = frozenset()
    deferred: tuple = ()
    rest_positions: np.ndarray | None = None
    instance: tuple = ()
    lighting: float = 0.0

    @property
    def effective_sh_degree(self) -> int:
        return max(0, min(self.sh_degree, self.splats.sh_degree))


@dataclass(frozen=True)
class Film:
    """A request for the frame in the terms of Blender's render result as well
    (RenderOutput.combined), made by a renderer that has_film, so the engine's conversion
    (blender/render/film.result_rect) need not run on the CPU.

    under: the scene-linear RGB of the world composited under the splats (alpha then 1);
    None leaves the film's alpha as the frame's."""

    under: tuple | None = None


@dataclass(frozen=True)
class RenderOptions:
    antialiased: bool = False          # gsplat's opacity compensation for the 0.3 px^2 low-pass
    # Stop a pixel at transmittance < 1e-4 (INRIA's tile rasterizer). The reference stops at
    # the exact splat; the GL renderer at the end of the front-to-back batch in which T fell
    # below 1e-4 (it moves a pixel by at most that 1e-4 of light). On by default: the GL
    # renderer then skips the splats hidden behind saturated pixels.
    early_termination: bool = True
    capped_extent: bool = False        # quads at min(3, sqrt(2 ln(255 o))) sigma, not the 1/255 contour: faster
    key_bits: int = 32                 # 16 or 32-bit depth sort keys
    # Offscreen renderer on GL >= 4.3: sort with compute shaders (True) or numpy (False);
    # None: compute shaders unless the GL is a software rasteriser (gl/sort.sorts_on_gpu)
    gpu_sort: bool | None = None
    background: tuple = (0.0, 0.0, 0.0, 0.0)  # premultiplied sRGB RGBA behind the splats
    # Opaque meshes that hide splats, per fragment (holdout.py): a splat's contribution to
    # a pixel is drawn only where its centre depth is below the nearest surface's there.
    # Compared and hashed by its key (a hash of the triangles).
    holdout: Holdout | None = None
    film: Film | None = None  # also return RenderOutput.combined (renderers that has_film)


@dataclass
class RenderOutput:
    """rgba: (H, W, 4) float32, premultiplied, display-referred sRGB, top-down rows.
    depth: (H, W) float32, the Z pass: the alpha-weighted view depth (-z) of the splats
    composited into the pixel, sum(T_i alpha_i z_i) / sum(T_i alpha_i) with z_i the view
    depth of splat i's centre and T_i alpha_i its share of the pixel's alpha (the weights
    that make its colour); inf where that alpha (the splats', without the background)
    stays below 0.5. Smooth along surfaces and through soft edges, which is what defocus
    and fog want from a Z pass; a faint floater in front moves it by its own small weight.
    Early termination, where on, ends the sum where it ends the colour.
    combined: None, or where options.film asked a renderer that has_film, the Combined pass
    of Blender's render result: (H * W * 4,) float32, bottom-up rows, premultiplied
    scene-linear, over Film.under where given; blender/render/film.result_rect(rgba,
    Film.under) to float32 rounding (pinned by tests/gl/test_film_pass.py)."""

    rgba: np.ndarray
    depth: np.ndarray
    combined: np.ndarray | None = None
