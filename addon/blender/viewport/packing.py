"""The layout the viewport shaders read: splat data as texels, the per-object table and
the view's push constants (no bpy, no gpu).

Three data textures, so that an effect changing only some fields re-uploads only their
texture (each is cached by the identity of the arrays it is built from):
    pos    RGBA32F, 1 texel per splat: position xyz (object space), opacity; the opacity
           is NaN for a splat no renderer draws (zero or non-finite quaternion, scale or
           SH), the one validity test the shader makes besides the position's
    shape  RGBA16F, a stream of SHAPE_VALUES halves per splat: the quaternion's three
           smallest components (wxyz order, the largest dropped and made positive), the
           scales, whose signs carry the dropped component's index (bit 0 in x, bit 1 in
           y: the covariance needs only scale^2), and the SH DC rgb
    sh     RGBA16F, a stream of `values` halves per splat: the higher SH coefficients,
           coefficient-major (r, g, b of coefficient 0, then 1, ...), zero-padded
At SH degree 3 that is 16 + 18 + 90 bytes a splat, plus 4 for the draw order (R32F).
A stream of halves packs 4 to a texel without regard for splat boundaries: value v of
splat i is value i * per_splat + v of the stream. Values are rounded to half here
(round to nearest even, clamped to +-65504), so the upload converts nothing and every
Blender version and backend holds the same numbers (Blender's own float-to-half upload
keeps NaN in 4.5 but writes 0 in 5.0 and 5.2, and turns inf into 65504: hence the
validity mark in the float32 opacity).
Every texture is WIDTH texels wide; texel t lives at (t % WIDTH, t // WIDTH).
"""
from __future__ import annotations

import numpy as np

from ...core.camera import Camera
from ...core.clip_space import camera_from_projection
from ...core.preprocess import camera_in_object, j_clamp_bounds, split_float
from ...core.effects.common import for_blocks
from ...core.effects.morph import arc_signs
from ...core.splats import SplatSet, sh_coeff_count

WIDTH = 4096          # texels per row of every data texture
MAX_HEIGHT = 16384    # the smallest GL_MAX_TEXTURE_SIZE Blender supports
SHAPE_VALUES = 9
OBJECT_TEXELS = 11    # per-object table row: see object_rows
# a deferred morph's target, in the layouts of pos, shape and sh, and its centres (the
# shader reads those in their place where no object morphs)
MORPH = {"morph_pos": "pos", "morph_shape": "shape", "morph_sh": "sh", "morph_centres": "pos"}
# a deferred displace's two noise layers at the rest centres, a texel a splat (xyz, w 0)
DISPLACE = {"displace_a": "pos", "displace_b": "pos"}
HALF_MAX = 65504.0
HALF_TINY = 2.0 ** -24  # the smallest positive half: stands for a zero scale, keeping its sign
_OTHERS = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])


def sh_values(degree: int) -> int:
    return 3 * sh_coeff_count(degree)


def padded(texels: int) -> int:
    """Texel count rounded up to whole rows (at least one row)."""
    rows = max(1, -(-texels // WIDTH))
    if rows > MAX_HEIGHT:
        raise ValueError(f"{texels} texels do not fit a {WIDTH}x{MAX_HEIGHT} texture")
    return rows * WIDTH


def stream(values: int) -> np.ndarray:
    """A zeroed (texels, 4) float32 array holding `values` values in whole rows."""
    return np.zeros((padded(-(-values // 4)), 4), np.float32)


def halves(a: np.ndarray) -> np.ndarray:
    """float32 values exactly representable as halves: clamped, rounded, NaN -> 0."""
    a = np.nan_to_num(np.asarray(a, np.float32), nan=0.0, posinf=HALF_MAX, neginf=-HALF_MAX)
    return np.clip(a, -HALF_MAX, HALF_MAX).astype(np.float16).astype(np.float32)


HALF_NORMAL = 2.0 ** -14  # the smallest normal half: below it halves step by HALF_TINY


def halves_fast(a: np.ndarray) -> np.ndarray:
    """halves() without float16: the same values, several times faster (numpy converts
    to and from float16 one value at a time; halves_into works on the bits, block by block)."""
    a = np.asarray(a, np.float32)
    out = np.empty(a.shape, np.float32)
    flat = out.reshape(-1, 1) if a.ndim < 2 else out.reshape(a.shape[0], -1)
    halves_into(flat, a.reshape(flat.shape))
    return out


def halves_into(out: np.ndarray, a: np.ndarray, signs: np.ndarray | None = None) -> None:
    """out[:] = halves(a) for (N, k) arrays; out may be a strided view (columns of a
    stream). With `signs` ((N,) integers), out is shape_scales(a, signs) instead. Rows go
    block by block on the effects' threads, so each block's temporaries stay in cache."""
    a = np.asarray(a, np.float32)

    def block(rows):
        part = np.array(a[rows], np.float32)
        _round_to_halves(part)
        if signs is not None:
            _sign_scales(part, signs[rows])
        if out.flags.c_contiguous:
            out[rows] = part
        else:
            for c in range(part.shape[1]):  # a column at a time: several times faster than a block
                out[rows, c] = part[:, c]

    for_blocks(a.shape[0], block)


def _round_to_halves(x: np.ndarray) -> None:
    """halves(), in place on a contiguous float32 array. Normal halves keep 11 significant
    bits: round the float32 mantissa at bit 13, to nearest even, on the bits. Below
    HALF_NORMAL, |x| + 0.5 rounds to the float32 step there, 2^-24 = HALF_TINY, also to
    nearest even."""
    np.clip(x, -HALF_MAX, HALF_MAX, out=x)  # infinities too; NaN stays NaN ...
    if np.isnan(x.min()):  # (a NaN anywhere makes the minimum NaN)
        np.copyto(x, np.float32(0.0), where=np.isnan(x))  # ... and becomes 0 here
    magnitude = np.abs(x)
    small = magnitude < np.float32(HALF_NORMAL)
    any_small = bool(small.any())
    if any_small:  # (a size effect hiding splats makes half of them tiny: no gathers)
        half = np.float32(0.5)
        magnitude += half
        magnitude -= half
        tiny = np.copysign(magnitude, x, out=magnitude)
    bits = x.view(np.uint32)
    carry = bits >> np.uint32(13)
    carry &= np.uint32(1)
    carry += np.uint32(0xFFF)
    bits += carry
    bits &= np.uint32(0xFFFFE000)
    if any_small:
        np.copyto(x, tiny, where=small)


def _sign_scales(x: np.ndarray, largest: np.ndarray) -> None:
    """shape_scales' marks on (n, 3) rounded scales, in place: |scale| (a zero as
    HALF_TINY), the sign of x and y carrying bits 0 and 1 of `largest`."""
    np.abs(x, out=x)
    np.maximum(x, np.float32(HALF_TINY), out=x)  # positive halves below HALF_TINY are 0
    bits = x.view(np.uint32)
    index = largest.astype(np.uint32)
    bits[:, 0] |= (index & np.uint32(1)) << np.uint32(31)
    bits[:, 1] |= (index & np.uint32(2)) << np.uint32(30)


def drawable(splats: SplatSet, degree: int) -> np.ndarray:
    """(N,) bool: quaternion non-zero and finite, scales and SH up to `degree` finite.
    The readable whole: the renderer tests a field at a time (rotation_rows, finite_rows,
    rest_rows), pinned to this by tests/blender/viewport/test_viewport_speed_paths.py."""
    q = splats.rotations
    ok = np.isfinite(q).all(1) & (q != 0).any(1)
    ok &= np.isfinite(splats.scales).all(1) & np.isfinite(splats.sh_dc).all(1)
    k = sh_coeff_count(max(0, min(degree, splats.sh_degree)))
    if k:
        ok &= np.isfinite(splats.sh_rest[:, :k]).reshape(splats.count, -1).all(1)
    return ok


def finite_rows(a: np.ndarray) -> np.ndarray:
    """(N,) bool: every value of the row finite. drawable() a field at a time, so a
    renderer keeps the masks of fields an effect left alone; the common all-finite
    case costs two reductions (NaN and inf show in the min or the max), not a row test."""
    a = np.asarray(a).reshape(a.shape[0], -1)
    if a.size == 0 or (np.isfinite(a.min()) and np.isfinite(a.max())):
        return np.ones(a.shape[0], bool)
    return np.isfinite(a).all(1)


def rotation_rows(q: np.ndarray) -> np.ndarray:
    """(N,) bool: the quaternion finite and not zero (drawable()'s rotation part)."""
    q = np.ascontiguousarray(q, np.float32)
    # four bools a row read as one uint32: 16x faster than .all(1) / .any(1) on (N, 4)
    finite = np.isfinite(q).view(np.uint32).reshape(-1) == 0x01010101
    return finite & ((q != 0).view(np.uint32).reshape(-1) != 0)


def rest_rows(splats: SplatSet, degree: int) -> np.ndarray:
    """(N,) bool: the higher SH coefficients up to `degree` finite (drawable()'s SH part)."""
    k = sh_coeff_count(max(0, min(degree, splats.sh_degree)))
    return finite_rows(splats.sh_rest[:, :k]) if k else np.ones(splats.count, bool)


def pack_pos(splats: SplatSet, ok: np.ndarray) -> np.ndarray:
    """The pos stream in one go (ok: drawable(splats, degree)): the layout that
    staging.PosStage keeps and rewrites in parts, pinned to this by its tests."""
    flat = np.zeros((padded(splats.count), 4), np.float32)
    view = flat[:splats.count]
    view[:, :3] = splats.positions
    view[:, 3] = np.where(ok, splats.opacities, np.float32(np.nan))
    return flat


def pack_xyz(positions: np.ndarray | None, count: int) -> np.ndarray:
    """Centres as pos-texture texels (w 0); None: zeros for `count` splats."""
    flat = np.zeros((padded(count), 4), np.float32)
    if positions is not None:
        for axis in range(3):  # a column at a time: 3.5x faster than flat[:n, :3] = ...
            flat[:count, axis] = positions[:, axis]
    return flat


def smallest_three(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) the normalised quaternion's three smallest components with the largest made
    positive (q and -q are one rotation), and (N,) the index of the largest."""
    q = np.asarray(q, np.float64)
    with np.errstate(all="ignore"):
        q = q / np.linalg.norm(q, axis=1, keepdims=True)
    q = np.nan_to_num(q)  # undrawable splats (pack_pos marks them): any value will do
    largest = np.argmax(np.abs(q), axis=1)
    q *= np.where(q[np.arange(q.shape[0]), largest] < 0, -1.0, 1.0)[:, None]
    return np.take_along_axis(q, _OTHERS[largest], axis=1), largest


def shape_rotation(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The shape stream's rotation part: (N, 3) halves and (N,) int8, the dropped index.
    halves_fast(smallest_three(q)) a block at a time on the effects' threads, on contiguous
    float64 columns (argmax, take_along_axis and norm over rows of four cost 4x more);
    pinned to it bit for bit by tests/blender/viewport/test_viewport_speed_paths.py."""
    n = q.shape[0]
    three, largest = np.empty((n, 3), np.float32), np.empty(n, np.int8)

    def block(rows):
        c = np.array(q[rows], np.float64).T.copy()  # four contiguous columns w, x, y, z
        norm = c[0] * c[0]
        for k in (1, 2, 3):
            norm += c[k] * c[k]
        with np.errstate(all="ignore"):
            c /= np.sqrt(norm, out=norm)
        np.nan_to_num(c, copy=False)
        size = np.abs(c)
        big = np.zeros(c.shape[1], np.int8)
        best = size[0]
        for k in (1, 2, 3):  # strictly greater: the first of equals wins, as argmax
            big[size[k] > best] = k
            best = np.maximum(best, size[k])
        c *= np.where(np.choose(big, c) < 0.0, -1.0, 1.0)
        part = np.empty((c.shape[1], 3), np.float32)
        for j in range(3):  # _OTHERS[big][j]: component j, or j + 1 at or after the dropped one
            part[:, j] = np.where(big <= j, c[j + 1], c[j])
        _round_to_halves(part)
        three[rows], largest[rows] = part, big

    for_blocks(n, block)
    return three, largest


def stored_signs(q: np.ndarray, largest: np.ndarray) -> np.ndarray:
    """(N,) float32 +-1: what shape_rotation multiplied each quaternion by (its largest
    component made positive)."""
    kept = np.take_along_axis(np.asarray(q, np.float32), largest.astype(np.int64)[:, None], axis=1)[:, 0]
    return np.where(kept < 0.0, np.float32(-1.0), np.float32(1.0))


def pack_morph_target(source_q: np.ndarray, target: SplatSet, degree: int) -> np.ndarray:
    """A deferred morph's target in the pos layout: w the opacity (NaN where not drawable),
    x the sign the shader turns the target's stored quaternion by so that its slerp takes
    the kernel's arc (morph.arc_signs, undoing what shape_rotation's signs did to both);
    y, z unused."""
    flat = pack_pos(target, drawable(target, degree))
    n = target.count
    signs = arc_signs(source_q, target.rotations)
    signs *= stored_signs(source_q, shape_rotation(source_q)[1])
    signs *= stored_signs(target.rotations, shape_rotation(target.rotations)[1])
    flat[:n, 0] = signs
    flat[:n, 1:3] = 0.0
    return flat


def shape_scales(scales: np.ndarray, largest: np.ndarray) -> np.ndarray:
    """The shape stream's scale part: |scale| as halves (a zero as HALF_TINY, the smallest
    positive half), signs carrying `largest`. The readable whole; halves_into(out, scales,
    largest) writes the same into a stream's columns."""
    out = np.abs(halves(scales))
    out[out == 0] = HALF_TINY
    out[:, 0] *= np.where(largest & 1, -1.0, 1.0)
    out[:, 1] *= np.where(largest & 2, -1.0, 1.0)
    return out


def pack_shape(splats: SplatSet) -> np.ndarray:
    """The shape stream in one go: the layout that staging.ShapeStage keeps and rewrites
    in parts, pinned to this by its tests."""
    n = splats.count
    flat = stream(n * SHAPE_VALUES)
    view = flat.reshape(-1)[:n * SHAPE_VALUES].reshape(n, SHAPE_VALUES)
    three, largest = shape_rotation(splats.rotations)
    view[:, 0:3] = three
    view[:, 3:6] = shape_scales(splats.scales, largest)
    view[:, 6:9] = halves_fast(splats.sh_dc)
    return flat


def pack_sh(splats: SplatSet, degree: int, values: int) -> np.ndarray:
    """Coefficients up to `degree`, `values` halves per splat (values >= sh_values(degree))."""
    n = splats.count
    flat = stream(n * values)
    k = sh_coeff_count(max(0, min(degree, splats.sh_degree)))
    if k and n:
        view = flat.reshape(-1)[:n * values].reshape(n, values)
        halves_into(view[:, :3 * k], splats.sh_rest[:, :k].reshape(n, 3 * k))
    return flat


def concatenate(parts: list[np.ndarray], counts: list[int], per_splat: int) -> np.ndarray:
    """Several objects' streams (`per_splat` values each) as one stream, in order."""
    flat = stream(sum(counts) * per_splat)
    out = flat.reshape(-1)
    start = 0
    for part, n in zip(parts, counts):
        out[start:start + n * per_splat] = part.reshape(-1)[:n * per_splat]
        start += n * per_splat
    return flat


def object_rows(local_to_camera: np.ndarray, splat_scale: float, opacity_scale: float,
                sh_degree: int, mode: int, sh_only: bool, color_matrix: np.ndarray,
                ortho: bool, first: int, effects: tuple = (0, 0, False, 0.0),
                data_first: int | None = None, lighting: float = 0.0) -> np.ndarray:
    """(OBJECT_TEXELS, 4) float32 for one object (layout in viewport_preprocess_frag.glsl).
    first: the object's first splat in the drawn splats, which the order indexes (exact in
    float to 2^24); data_first: its first splat in the data textures (default first):
    instances of one object share its data, each drawn with its own row.
    effects: its deferred colour effects' first table texel, count, whether they read
    the rest centres' texture (effect_rows.py), and a deferred morph's amount (0: none).
    lighting: its Look > Lighting, which the preprocess pass applies (0: unlit)."""
    m = np.asarray(local_to_camera, np.float64)
    eye, forward = camera_in_object(m)
    eye_hi, eye_lo = split_float(eye)
    rows = np.zeros((OBJECT_TEXELS, 4), np.float32)
    rows[0:3, :3] = m[:3, :3].T  # columns of cam_from_local
    rows[0, 3], rows[1, 3], rows[2, 3] = splat_scale, opacity_scale, sh_degree
    rows[3, :3], rows[3, 3] = eye_hi, mode
    rows[4, :3], rows[4, 3] = eye_lo, float(sh_only)
    rows[5:8] = np.asarray(color_matrix, np.float32).reshape(3, 4)
    rows[8, :3] = forward if ortho else 0.0
    rows[8, 3] = first
    rows[9] = effects
    rows[10, 0] = first if data_first is None else data_first
    rows[10, 1] = lighting
    return rows


def view_constants(projection: np.ndarray, width: int, height: int, *, antialiased=False,
                   capped_extent=False, linear_output=False, point_size=2.0) -> dict:
    """Push constants from an OpenGL projection matrix and the viewport size in pixels."""
    p = np.asarray(projection, np.float64)
    cam: Camera = camera_from_projection(p, width, height)
    lo_x, hi_x, lo_y, hi_y = j_clamp_bounds(cam)
    return {
        "focal_centre": (cam.fx, cam.fy, cam.cx, cam.cy),
        "jac_bounds": (lo_x, lo_y, hi_x, hi_y),
        "frame": (float(width), float(height), cam.near, cam.far),
        "proj_z": (p[2, 2], p[2, 3], p[3, 2], p[3, 3]),
        "misc": (float(point_size), 0.0, 0.0, 0.0),
        "flags": (int(cam.ortho), int(antialiased), int(capped_extent), int(linear_output)),
    }
