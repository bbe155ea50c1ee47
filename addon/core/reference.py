"""The float64 reference renderer: per pixel, exact, slow. The oracle for every
other renderer (semantics in docs/DESIGN.md, projection in preprocess.py).

- Order: one global order over every item's splats by the view depth of the
  centre. Exact ties: the lower global index (item order, then splat order) is
  in front, as INRIA's and gsplat's stable front-to-back key sorts give.
- Pixels: pixel (i, j) is sampled at its centre (i + 0.5, j + 0.5), with u, v
  measured from the top-left corner of the frame. This is INRIA's convention:
  its ndc2Pix maps the frame to [-0.5, W - 0.5] and samples at integer pixel
  coordinates, i.e. our centres shifted by half a pixel.
- A splat touches the pixels whose centres lie in its screen-aligned square
  quad, |u_pixel - u| <= radius and |v_pixel - v| <= radius (radius from
  preprocess.py, a float: what a quad rasterizer covers). There alpha =
  min(0.99, o exp(-d^T conic d / 2)) (0.99 is INRIA's cap), and alpha < 1/255
  is dropped. The quad reaches the 1/255 contour, so the footprint is exact:
  every pixel centre with alpha >= 1/255 and no other. options.capped_extent
  cuts the quad at 3 sigma, as the fast paths do when asked to for speed.
- Compositing runs front to back: C += T alpha c, T *= (1 - alpha), film
  alpha = 1 - T. Without early termination this equals back-to-front
  premultiplied "over" (C = alpha c + (1 - alpha) C) up to float64 rounding;
  front to back is what makes INRIA's early termination expressible: with
  options.early_termination, the splat that would take T below 1e-4 is not
  blended and the pixel stops there.
- Equirect cameras: a splat whose quad reaches past the left or right edge is also
  drawn one longitude period over (equirect.seam_shifts), so it shows across the seam.
- The background (premultiplied) goes behind everything: C + T bg.
- Depth (the Z pass): the alpha-weighted view depth of the splats blended into the
  pixel, sum(T_i alpha_i z_i) / (1 - T), z_i the view depth of splat i's centre; inf
  where the splats' alpha 1 - T stays below DEPTH_FROM_ALPHA (0.5).
- Holdout (options.holdout, holdout.py): a splat's fragment at a pixel is composited
  only where its centre depth is below the pixel's holdout depth (the nearest opaque
  surface); a dropped fragment changes neither colour, transmittance nor the Z pass, so
  the Z pass is that of the kept fragments, and early termination counts only them.
- Work is per splat over the pixels of its bounding box, tile by tile, so a
  few small splats on an 8192 x 8192 frame cost little beyond the output.
"""
from __future__ import annotations

import numpy as np

from . import equirect
from .camera import Camera
from .holdout import holdout_depth, kept
from .preprocess import project
from .render_constants import ALPHA_MIN, DEPTH_FROM_ALPHA, MAX_ALPHA, T_STOP
from .scene import RenderItem, RenderOptions, RenderOutput

TILE = 256


class ReferenceRenderer:
    """render() below as a core.renderer.Renderer (it keeps no state between frames)."""

    has_depth = has_holdout = has_panorama = has_defocus = has_early_termination = True
    has_film = False  # the oracle of the frame itself; the film is the engine's step

    def render(self, items, camera, options):
        return render(items, camera, options)

    def close(self):
        pass


def render(items: list[RenderItem], camera: Camera, options: RenderOptions = RenderOptions(),
           window: tuple[int, int, int, int] | None = None) -> RenderOutput:
    """Render items through camera: premultiplied sRGB RGBA + depth, float32, top-down.

    window (x, y, width, height) renders only those pixels of the camera's frame, with
    the frame's own projection (J clamp included): a crop of a huge frame, exactly.
    A crop *camera* would differ where the clamp window follows the frame's edges."""
    wx, wy, w, h = window if window is not None else (0, 0, camera.width, camera.height)
    if not (0 <= wx and 0 <= wy and w > 0 and h > 0 and wx + w <= camera.width and wy + h <= camera.height):
        raise ValueError(f"window {window} is not inside the {camera.width}x{camera.height} frame")
    splats = _gather(items, camera, options)
    rgba = np.empty((h, w, 4), np.float32)
    depth = np.empty((h, w), np.float32)
    bg = np.asarray(options.background, np.float64)
    held = (None if options.holdout is None  # nearest surface per pixel, float64
            else holdout_depth(options.holdout, camera, (wx, wy, w, h)))
    for y0 in range(wy, wy + h, TILE):
        for x0 in range(wx, wx + w, TILE):
            y1, x1 = min(y0 + TILE, wy + h), min(x0 + TILE, wx + w)
            out = (slice(y0 - wy, y1 - wy), slice(x0 - wx, x1 - wx))
            c, t, d = _render_tile(splats, x0, y0, x1, y1, options.early_termination,
                                   None if held is None else held[out])
            rgba[out + (slice(0, 3),)] = c + t[..., None] * bg[:3]
            rgba[out + (3,)] = (1.0 - t) + t * bg[3]
            depth[out] = d
    return RenderOutput(rgba, depth)


def _gather(items, camera, options) -> dict:
    """Every item's visible splats, concatenated in front-to-back order, with
    their inclusive pixel bounding boxes (clipped to the frame)."""
    fields = ("means2d", "conic", "opacity", "rgb", "depth", "radius")
    parts = {f: [] for f in fields}
    for item in items:
        p = project(item, camera, options.antialiased, options.capped_extent)
        for f in fields:
            parts[f].append(getattr(p, f)[p.valid])
    if not items:
        parts = {f: [np.zeros((0, 2) if f == "means2d" else (0, 3) if f in ("conic", "rgb")
                              else (0,))] for f in fields}
    s = {f: np.concatenate(v) for f, v in parts.items()}
    if camera.equirect:
        s = _with_seam_copies(s, camera)
    front_to_back = np.argsort(s["depth"], kind="stable")  # ties: lower index first
    s = {f: v[front_to_back] for f, v in s.items()}
    u, v, r = s["means2d"][:, 0], s["means2d"][:, 1], s["radius"]
    # pixel i is inside when |i + 0.5 - u| <= r; clip in float before the int cast
    box = np.stack([np.ceil(u - r - 0.5), np.floor(u + r - 0.5),
                    np.ceil(v - r - 0.5), np.floor(v + r - 0.5)], 1)
    box = np.clip(box, [0, -1, 0, -1], [camera.width, camera.width - 1,
                                        camera.height, camera.height - 1]).astype(np.int64)
    keep = (box[:, 0] <= box[:, 1]) & (box[:, 2] <= box[:, 3])
    s = {f: v[keep] for f, v in s.items()}
    s["box"] = box[keep]
    return s


def _with_seam_copies(s: dict, camera) -> dict:
    """Append the seam copies (after every original, so a copy never wins a depth tie
    against another splat's original)."""
    parts = {f: [v] for f, v in s.items()}
    for idx, shift in equirect.seam_shifts(s["means2d"][:, 0], s["radius"], camera):
        for f, v in s.items():
            parts[f].append(v[idx])
        parts["means2d"][-1] = parts["means2d"][-1] + (shift, 0.0)
    return {f: np.concatenate(v) for f, v in parts.items()}


def _render_tile(s: dict, x0: int, y0: int, x1: int, y1: int, early_termination: bool,
                 held=None):
    """Composite the splats overlapping [x0, x1) x [y0, y1): colour, transmittance, depth.
    held: the tile's holdout depth, or None."""
    h, w = y1 - y0, x1 - x0
    col = np.zeros((h, w, 3))
    trans = np.ones((h, w))
    weighted = np.zeros((h, w))  # sum of T alpha z
    done = np.zeros((h, w), bool)
    box = s["box"]
    hits = np.nonzero((box[:, 0] < x1) & (box[:, 1] >= x0) & (box[:, 2] < y1) & (box[:, 3] >= y0))[0]
    for i in hits:
        bx0, bx1 = max(box[i, 0], x0), min(box[i, 1] + 1, x1)
        by0, by1 = max(box[i, 2], y0), min(box[i, 3] + 1, y1)
        dx = (np.arange(bx0, bx1) + 0.5 - s["means2d"][i, 0])[None, :]
        dy = (np.arange(by0, by1) + 0.5 - s["means2d"][i, 1])[:, None]
        ca, cb, cc = s["conic"][i]
        m2 = ca * dx * dx + 2.0 * cb * dx * dy + cc * dy * dy
        alpha = np.minimum(MAX_ALPHA, s["opacity"][i] * np.exp(-0.5 * m2))
        sl = (slice(by0 - y0, by1 - y0), slice(bx0 - x0, bx1 - x0))
        mask = (alpha >= ALPHA_MIN) & ~done[sl]
        if held is not None:
            mask &= kept(s["depth"][i], held[sl])
        t = trans[sl]
        if early_termination:
            stop = mask & (t * (1.0 - alpha) < T_STOP)
            done[sl] |= stop
            mask &= ~stop
        a = np.where(mask, alpha, 0.0)
        col[sl] += (t * a)[..., None] * s["rgb"][i]
        weighted[sl] += t * a * s["depth"][i]
        trans[sl] = t * (1.0 - a)
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = np.where(1.0 - trans >= DEPTH_FROM_ALPHA, weighted / (1.0 - trans), np.inf)
    return col, trans, depth
