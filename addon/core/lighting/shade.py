"""Lambert shading of splats by Blender's lights, in Cycles' units, applied as an exact change
of each splat's SH colour (issue 43). Pure numpy, float64; one pass per frame, per splat, so
every renderer (the float64 reference, the GL renderer, the viewport) draws the same lit
splats with no shader of its own.

The model. A splat's colour as trained (its view-independent part, the SH DC: display-
referred sRGB) is its albedo under the light it was filmed in; decoded to linear, `a`. Lit,
it sends out
    L = a * (W + sum over lights of  E_l * max(0, n . l) * V_l / pi)
with W the World's colour x strength (a uniform environment gives a Lambert surface
albedo x W: a white World of strength 1 shows the capture as filmed), n the splat's normal
(normals.py), l the unit direction to the light, V_l in [0, 1] its visibility (shadows.py;
1 without shadows) and E_l the light's irradiance on a surface facing it, as Cycles gives it
(measured against Cycles, tests/blender/render/test_lighting_cycles.py):
- SUN: strength S W/m^2, E = S;
- POINT: power P W, E = P / (4 pi d^2); its radius is ignored (a point);
- SPOT: a point light of the same power, times Blender's cone mask
  smoothstep((cos a - cos(size / 2)) / ((1 - cos(size / 2)) * blend)), a the angle off its axis;
- AREA: a point with a cosine emission lobe, E = P cos(e) / (pi d^2), e the angle off its
  normal (the light's -Z): exact for a small light, and within a few per cent beyond about
  three light sizes away.
Each light's colour multiplies E. The lit display colour is sRGB(L); the splat's colour is
multiplied by k = sRGB(L) / c per channel, c its DC colour, which changes its SH exactly:
every coefficient x k and the DC also + (k - 1) 0.5 / C0, so that 0.5 + SH becomes
k (0.5 + SH) for every view direction (and the renderers' clamp at 0 commutes with k >= 0).
The view-dependent part is scaled with the DC: the lit surface keeps its sheen.
`amount` (Look > Lighting) blends k with 1: at 0 nothing is computed or changed.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..colorspace import linear_to_srgb, srgb_to_linear
from ..sh import C0
from .lights import Light
from .normals import splat_normals

_DARK = 1e-6    # a DC colour below this is black: lit, it stays black


@dataclass(frozen=True)
class Lighting:
    """What lights a frame: the lights, the World's uniform colour (linear, x strength), the
    point normals face (the scene camera), and whether lights cast shadows."""
    lights: tuple = ()
    ambient: tuple = (0.0, 0.0, 0.0)
    eye: tuple | None = (0.0, 0.0, 0.0)   # None: no camera, both sides of a splat lit


def _cosine(cos: np.ndarray, two_sided: bool) -> np.ndarray:
    return np.abs(cos) if two_sided else np.maximum(cos, 0.0)


def irradiance(light: Light, points: np.ndarray, normals: np.ndarray, two_sided: bool = False) -> np.ndarray:
    """(N,) E_l * max(0, n . l) of one light (colour apart), W/m^2; two-sided: |n . l|."""
    if light.kind == "SUN":
        to_light = -light.direction_array / np.linalg.norm(light.direction_array)
        return light.strength * _cosine(normals @ to_light, two_sided)
    offset = light.position_array[None, :] - points
    d2 = np.einsum("ij,ij->i", offset, offset)
    d2 = np.maximum(d2, 1e-12)
    l = offset / np.sqrt(d2)[:, None]
    cos_n = _cosine(np.einsum("ij,ij->i", normals, l), two_sided)
    axis = light.direction_array / np.linalg.norm(light.direction_array)
    cos_axis = -(l @ axis)  # the angle off the light's axis, seen from the light
    if light.kind == "AREA":
        return light.power * np.maximum(cos_axis, 0.0) * cos_n / (np.pi * d2)
    e = light.power / (4.0 * np.pi * d2) * cos_n
    if light.kind == "SPOT":
        e = e * spot_mask(cos_axis, light.spot_size, light.spot_blend)
    return e


def spot_mask(cos_axis: np.ndarray, size: float, blend: float) -> np.ndarray:
    """Blender's spot cone: 0 outside, a smoothstep over the blend's share inside its edge."""
    cos_half = np.cos(size / 2.0)
    inside = cos_axis > cos_half
    if blend <= 0.0:
        return inside.astype(np.float64)
    t = np.clip((cos_axis - cos_half) / ((1.0 - cos_half) * blend), 0.0, 1.0)
    return np.where(inside, t * t * (3.0 - 2.0 * t), 0.0)


def radiance_factor(lighting: Lighting, points: np.ndarray, normals: np.ndarray,
                    visibility=None) -> np.ndarray:
    """(N, 3) W + sum_l colour_l E_l max(0, n.l) V_l / pi: the lit linear colour of albedo 1.
    visibility: None, or one (N,) array in [0, 1] per light (shadows.py), in lights' order."""
    out = np.broadcast_to(np.asarray(lighting.ambient, np.float64), (len(points), 3)).copy()
    for i, light in enumerate(lighting.lights):
        e = irradiance(light, points, normals, lighting.eye is None) / np.pi
        if visibility is not None and visibility[i] is not None:
            e = e * visibility[i]
        out += e[:, None] * np.asarray(light.color, np.float64)[None, :]
    return out


def lit_splats(splats, world: np.ndarray, lighting: Lighting, amount: float, visibility=None,
               points=None, normals=None):
    """The splats lit by `lighting` at Look > Lighting `amount` (new sh_dc and sh_rest; the
    rest shared). amount 0: the splats themselves, untouched. points, normals: what
    normals.splat_normals gives for them, where the caller has it (the viewport keeps it
    while only lights move; the shadows need the points)."""
    if amount <= 0.0 or splats.count == 0:
        return splats
    if normals is None:
        points, normals = splat_normals(splats, world, lighting.eye, points)
    factor = radiance_factor(lighting, points, normals, visibility)
    return with_colour_factor(splats, colour_factor(splats.sh_dc, factor, amount))


def colour_factor(sh_dc: np.ndarray, radiance: np.ndarray, amount: float) -> np.ndarray:
    """(N, 3) k >= 0: sRGB(albedo x radiance) / c, blended with 1 by amount."""
    c = 0.5 + C0 * sh_dc.astype(np.float64)
    albedo = srgb_to_linear(np.maximum(c, 0.0))
    # a negative light (Blender allows them) darkens to black, no further: k < 0 would turn
    # the SH's lobes below 0.5 bright
    lit = linear_to_srgb(albedo * np.maximum(radiance, 0.0))
    k = np.where(c > _DARK, lit / np.where(c > _DARK, c, 1.0), 1.0)
    return 1.0 + float(min(amount, 1.0)) * (k - 1.0)


def with_colour_factor(splats, k: np.ndarray):
    """Splats whose colour, in every view direction, is k times theirs (k >= 0, (N, 3))."""
    dc = (k * (0.5 + C0 * splats.sh_dc.astype(np.float64)) - 0.5) / C0
    rest = splats.sh_rest
    if rest.size:  # in float32, as stored: a float64 copy of degree 3's 45 floats a splat cost 9x the time
        rest = rest * k.astype(np.float32)[:, None, :]
    return replace(splats, sh_dc=dc.astype(np.float32), sh_rest=rest)
