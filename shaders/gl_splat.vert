// Offscreen renderer, stage "draw": one instanced screen-aligned quad per sorted splat,
// FRONT TO BACK: instance i of a batch draws front-to-back rank u_first + i (the order
// buffer itself is back to front). Pixels are top-left-origin, y down, and so are the
// targets' rows: the frame's top row is GL's row 0, so a read-back needs no flip.
// GL 4.3: records in storage buffers, order[k] from the sort. GL 3.3 fallback
// (SL_TEXTURE_RECORDS): records already sorted on the CPU, in RGBA32F textures.
#include_records

uniform vec2 u_frame;    // full frame width, height
uniform vec4 u_tile;     // x0, y0, width, height of the rendered tile, in frame pixels
uniform uint u_visible;  // splats in the frame's order
uniform uint u_first;    // front-to-back rank of this batch's first splat

#ifdef SL_SATURATION_MAP
// Early termination (gl_saturation_map.comp): a splat whose footprint covers only
// saturated pixels is dropped here, before the rasterizer visits its pixels, and one
// whose unsaturated cells lie in a box well inside its quad is drawn as that box.
layout(std430, binding = 8) readonly buffer Saturation { uint sat_flags[]; };
uniform int u_sat_levels;  // 0: no map yet (first batch, or early termination off)
const float SL_TRIM_AREA = 0.8;  // trim to the open cells below this share of the rectangle
uniform uint u_sat_offset[SL_SATURATION_MAP];  // level k's first word
uniform uvec2 u_sat_size[SL_SATURATION_MAP];   // its words per row, rows

// bits of cells x0 .. x0 + n - 1 (n <= 32) of row y at level k, set where saturated
uint sat_bits(int k, uint x0, uint n, uint y)
{
    uint at = u_sat_offset[k] + y * u_sat_size[k].x + (x0 >> 5u), shift = x0 & 31u;
    uint bits = sat_flags[at] >> shift;
    if (shift + n > 32u) bits |= sat_flags[at + 1u] << (32u - shift);
    return n == 32u ? bits : bits & ((1u << n) - 1u);
}

// The frame-pixel box [xy, zw] around the unsaturated pixels within `extent` (half-size
// of the footprint's bounding box; one pixel of slack each side), in whole cells of the
// finest level where that box spans at most 32 cells across and 8 down (a row is one or
// two loads); empty (x > z) where all are saturated, unbounded where no level is that
// coarse or there is no map yet.
vec4 open_cells(vec2 centre, vec2 extent)
{
    const vec4 unbounded = vec4(-1e30, -1e30, 1e30, 1e30);
    vec2 lo = max(floor(centre - extent - 0.5) - u_tile.xy, vec2(0.0));
    vec2 hi = min(ceil(centre + extent - 0.5) - u_tile.xy, u_tile.zw - 1.0);
    if (u_sat_levels == 0 || any(greaterThan(lo, hi))) return unbounded;
    uvec2 a = uvec2(lo), b = uvec2(hi);
    for (int k = 0; k < u_sat_levels; k++) {
        uint shift = uint(2 + k);
        uvec2 ca = a >> shift, cb = b >> shift;
        if (cb.x - ca.x > 31u || cb.y - ca.y > 7u) continue;
        uint n = cb.x - ca.x + 1u, first = 32u, last = 0u, top = cb.y + 1u, bottom = ca.y;
        uint full = n == 32u ? 0xFFFFFFFFu : (1u << n) - 1u;
        for (uint y = ca.y; y <= cb.y; y++) {
            uint open = ~sat_bits(k, ca.x, n, y) & full;
            if (open != 0u) {
                first = min(first, uint(findLSB(open)));
                last = max(last, uint(findMSB(open)));
                top = min(top, y);
                bottom = y;
            }
        }
        if (top > cb.y) return vec4(1.0, 0.0, 0.0, 0.0);  // all saturated
        float cell = float(1u << shift);
        return vec4(float(ca.x + first) * cell, float(top) * cell,
                    float(ca.x + last + 1u) * cell, float(bottom + 1u) * cell) + u_tile.xyxy;
    }
    return unbounded;
}
#endif

uniform bool u_capped_extent;  // quads cut at 3 sigma: keep the square (its corners are in)

#ifdef SL_HOLDOUT
// Holdout (issue 25, gl/holdout.py): the tile's depth buffer holds the nearest surface's
// depth under each pixel, encoded linearly (gl_holdout_resolve.frag); a splat's quad lies
// at its centre depth, encoded the same way and raised by SL_HOLDOUT_BIAS (twice the
// rounding of the two encodings, the viewport transform and the 24-bit depth buffer), so
// the depth test (LESS, no depth writes) keeps a fragment only where the centre lies in
// front of the surface: never one behind it (gl/composite.py, held_band).
uniform vec2 u_holdout_enc;  // lo, scale: enc(z) = SL_ENC_BASE + (z - lo) * scale
const float SL_ENC_BASE = 0.0625;
const float SL_HOLDOUT_BIAS = 9.5367431640625e-07;  // 2^-20, holdout.HOLDOUT_BIAS (gl/holdout.py)
#endif

// Half-axes (columns) of a rectangle holding the ellipse d^T conic d <= 2 ln(255 o), the
// pixels where alpha >= 1/255. The long half-axis is the square's radius (it is that
// ellipse's, from the same eigenvalue); the short one is padded for the float32 error
// of the axis direction (angle <= 8 eps |conic| / gap) and never exceeds the radius.
mat2 ellipse_box(vec3 conic, float opacity, float radius)
{
    float a = conic.x, b = conic.y, c = conic.z;
    float h = 0.5 * (a - c), root = sqrt(h * h + b * b);
    float mu_max = 0.5 * (a + c) + root;
    vec2 e1 = vec2(b, mu_max - a), e2 = vec2(mu_max - c, b);
    vec2 minor_dir = dot(e1, e1) > dot(e2, e2) ? e1 : e2;
    float len = length(minor_dir);
    float angle = 8.0 * 1.2e-7 * mu_max / max(2.0 * root, 1e-30);
    if (!(len > 0.0) || !(angle < 0.05)) return mat2(radius, 0.0, 0.0, radius);
    minor_dir /= len;
    float minor = sl_extent_sigma(opacity, false) * inversesqrt(mu_max);
    minor = min(radius, minor * 1.001 + radius * angle + 1e-3);
    return mat2(minor_dir * minor, vec2(-minor_dir.y, minor_dir.x) * radius);
}

// Half-size of the axis-aligned box of the alpha = 1/255 ellipse, r sqrt(diag(conic^-1)),
// padded like ellipse_box; it holds every pixel the quad can keep, capped or not (the
// uncapped cut is the larger), and for a tilted long ellipse it is far smaller than the
// box around its rectangle. Where the conic is near singular its determinant carries a
// relative float32 error ~ 1e-7 a c / det, so there the rectangle's box stands.
vec2 footprint_box(vec3 conic, float opacity, vec2 quad_box)
{
    float det = conic.x * conic.z - conic.y * conic.y;
    if (!(det > 1e-3 * conic.x * conic.z)) return quad_box;
    vec2 half_size = sl_extent_sigma(opacity, false) * sqrt(vec2(conic.z, conic.x) / det);
    return min(quad_box, half_size * 1.001 + 1e-3);
}

// the offset from the centre, whitened (sl_whiten): affine in the pixel position, so the
// rasteriser interpolates it from the corners, "noperspective" (w is 1: linear, and
// cheaper than "smooth" on llvmpipe). Every quad lies inside the tile, so no triangle
// reaches the clipper, which in Mesa 22.3's llvmpipe interpolates noperspective outputs
// wrongly on the triangles it cuts (tests/gl/test_gl_whiten.py)
noperspective out vec2 v_w;
flat out vec4 v_colour;  // rgb, opacity
flat out float v_depth;  // view depth of the centre (Z pass)

void main()
{
    uint k = u_visible - 1u - (u_first + uint(gl_InstanceID));
    vec4 r0 = record(0, k), r1 = record(1, k);
    vec3 conic = vec3(r0.zw, r1.x);
    v_colour = vec4(record(2, k).rgb, r1.w);
    v_depth = r1.z;
    vec2 corner = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1)) * 2.0 - 1.0;
    vec2 lo = u_tile.xy, hi = u_tile.xy + u_tile.zw;
    // the rectangle around the alpha = 1/255 ellipse along its axes: same pixels as the
    // square (the fragment stage adds nothing below 1/255), far fewer visited; used
    // where it lies inside the tile
    mat2 axes = u_capped_extent ? mat2(r1.y) : ellipse_box(conic, r1.w, r1.y);
    vec2 half_box = abs(axes[0]) + abs(axes[1]);
    bool tight = !u_capped_extent && all(greaterThanEqual(r0.xy - half_box, lo))
        && all(lessThanEqual(r0.xy + half_box, hi));
    if (!tight) {
        axes = mat2(r1.y);
        half_box = vec2(r1.y);
    }
    vec2 box = footprint_box(conic, r1.w, half_box);
#ifdef SL_SATURATION_MAP
    vec4 open = open_cells(r0.xy, box);
    if (open.x > open.z) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // outside the clip volume: nothing drawn
        return;
    }
    // where the unsaturated cells' box holds well under the rectangle's pixels, the square
    // cut to it instead: the saturated pixels left out take no more than the 1e-4 of light
    // early termination leaves out anyway
    vec2 open_size = max(min(open.zw, r0.xy + box) - max(open.xy, r0.xy - box), 0.0);
    if (tight && open_size.x * open_size.y < SL_TRIM_AREA * 4.0 * length(axes[0]) * length(axes[1])) {
        tight = false;
        axes = mat2(r1.y);
    }
    lo = max(lo, open.xy);
    hi = min(hi, open.zw);
#endif
    vec2 pix = r0.xy + axes * corner;
    if (!tight) {
        // otherwise the square, cut to the tile (so huge quads cost no more than it) and,
        // uncapped, to the ellipse's own box (box above: here from the square's (r, r))
        if (!u_capped_extent) {
            lo = max(lo, r0.xy - box);
            hi = min(hi, r0.xy + box);
        }
        if (any(greaterThan(lo, hi))) {
            gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // no pixel of the tile in reach
            return;
        }
        pix = clamp(pix, lo, hi);
    }
    v_w = sl_whiten(pix - r0.xy, conic);
    vec2 ndc = (pix - u_tile.xy) / u_tile.zw * 2.0 - 1.0;
#ifdef SL_HOLDOUT
    float enc = SL_ENC_BASE + (r1.z - u_holdout_enc.x) * u_holdout_enc.y + SL_HOLDOUT_BIAS;
    gl_Position = vec4(ndc.x, ndc.y, clamp(enc, 0.0, 0.9375) * 2.0 - 1.0, 1.0);
#else
    // z = 0.5 (window depth 0.75): behind GL 3.3's saturation marks (0.5), before the clear
    gl_Position = vec4(ndc.x, ndc.y, 0.5, 1.0);
#endif
}
