// Viewport (Blender gpu module), preprocess pass: one fragment per drawn splat computes
// its projection, footprint and colour once, for the quad pass's four vertices.
// Needs splat_math.glsl before this file; declarations come from GPUShaderCreateInfo
// (addon/blender/viewport/gpu_draw.py). Data layouts: addon/blender/viewport/packing.py.
//
// Fragment (x, y) of the record textures is draw position i = y * width + x (farthest
// first); order_tex maps it to the splat. Records (culled: all zero):
//   rec_pos    centre u, v (pixels, y down), NDC depth of the centre, quad half-size
//   rec_conic  conic a, b, c (px^-2), opacity after the look and antialiasing
//   rec_color  colour after SH, grade and output conversion; display mode (0, 1, 2)
// Per-object table (11 texels an object; table_texel reads it): columns of cam_from_local with splat scale,
// opacity scale, SH degree; eye hi + mode; eye lo + sh_only; the 3x4 colour matrix;
// orthographic view direction + the object's first splat index; the object's deferred
// effects (first texel, count, whether they read rest_tex), whose rows follow the objects',
// and a deferred morph's amount (0: none; the target's data in the morph_* textures); the
// object's first splat in the data textures (instances of one object share its data) and its
// Look > Lighting (0: unlit; the light table follows the objects' rows). A
// deferred morph or displace moves pos_tex's centre (then its source end's, or the stack's
// input) itself: towards the target's centre, or by the displace's noise layers.
// Everything is camera-relative: t = cam_from_local * (p - eye), eye split hi + lo.

const int OBJECT_TEXELS = 11;

vec4 object_texel(int object, int k)
{
    return table_texel(object * OBJECT_TEXELS + k);
}

// The object whose splats include `splat`: the last one starting at or before it.
int object_of(int splat)
{
    int lo = 0, hi = sizes.z - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (int(object_texel(mid, 8).w) <= splat) lo = mid; else hi = mid - 1;
    }
    return lo;
}

// Three smallest components + the index of the dropped largest -> quaternion (w, x, y, z).
vec4 quat_from_three(vec3 v, int largest)
{
    float l = sqrt(max(0.0, 1.0 - dot(v, v)));
    if (largest == 0) return vec4(l, v);
    if (largest == 1) return vec4(v.x, l, v.y, v.z);
    if (largest == 2) return vec4(v.x, v.y, l, v.z);
    return vec4(v, l);
}

// The higher SH coefficients of one splat in `tex` (a stream of halves, sizes.y a splat).
void sh_rest_of(sampler2D tex, int splat, int coeffs, out vec3 rest[15])
{
    for (int k = 0; k < 15; k++) rest[k] = vec3(0.0);
    int base = splat * sizes.y, off = base % 4;
    int used = (off + 3 * coeffs + 3) / 4;
    vec4 tx[12];
    for (int j = 0; j < 12; j++) {
        tx[j] = j < used ? fetch(tex, base / 4 + j) : vec4(0.0);
    }
    for (int k = 0; k < coeffs; k++) {
        int c = off + 3 * k;
        rest[k] = vec3(tx[c / 4][c % 4], tx[(c + 1) / 4][(c + 1) % 4], tx[(c + 2) / 4][(c + 2) % 4]);
    }
}

vec3 sh_colour(int splat, vec3 dir, int degree, vec3 dc, bool sh_only, float morph)
{
    vec3 rest[15];
    for (int k = 0; k < 15; k++) rest[k] = vec3(0.0);
    int coeffs = (degree + 1) * (degree + 1) - 1;
    if (coeffs > 0 && sizes.y > 0) {
        sh_rest_of(sh_tex, splat, coeffs, rest);
        if (morph > 0.0) {  // morph.blend's lerp, a + (b - a) t, on each coefficient
            vec3 other[15];
            sh_rest_of(morph_sh_tex, splat, coeffs, other);
            for (int k = 0; k < coeffs; k++) rest[k] = rest[k] + (other[k] - rest[k]) * morph;
        }
    }
    // "show SH only": the higher bands over grey, without the DC term
    return sl_sh_color(dir, degree, sh_only ? vec3(0.0) : dc, rest);
}

// The shape stream's values of one splat: quaternion (w, x, y, z), |scale|, SH DC.
void shape_of(sampler2D tex, int splat, out vec4 q, out vec3 scale, out vec3 dc)
{
    int base = splat * 9, off = base % 4;
    vec4 tx[3];
    for (int j = 0; j < 3; j++) tx[j] = fetch(tex, base / 4 + j);
    float v[9];
    for (int k = 0; k < 9; k++) v[k] = tx[(off + k) / 4][(off + k) % 4];
    vec3 s = vec3(v[3], v[4], v[5]);
    q = quat_from_three(vec3(v[0], v[1], v[2]), int(s.x < 0.0) + 2 * int(s.y < 0.0));
    scale = abs(s);
    dc = vec3(v[6], v[7], v[8]);
}

// morph.slerp: b turned by `turn` onto a's hemisphere (the kernel's arc: its sign is the
// CPU's, as near q.q' = 0 rounding could pick the other), nlerp where sin(theta) < 1e-5
vec4 morph_slerp(vec4 a, vec4 b, float turn, float t)
{
    b *= turn;
    float theta = acos(min(abs(dot(a, b)), 1.0));
    float s = sin(theta);
    bool near = s < 1e-5;
    float w0 = near ? 1.0 - t : sin(theta * (1.0 - t)) / s;
    float w1 = near ? t : sin(theta * t) / s;
    vec4 q = a * w0 + b * w1;
    return q / max(length(q), 1e-12);
}

// A deferred morph (core/effects/deferral.py): this splat blended with the target's splat
// of the same index, as morph.blend does (the centre: main).
void morph_splat(int splat, float t, inout float opacity, inout vec3 scale, inout vec4 q,
                 inout vec3 dc)
{
    vec4 other_q;
    vec3 other_scale, other_dc;
    shape_of(morph_shape_tex, splat, other_q, other_scale, other_dc);
    vec4 other = fetch(morph_pos_tex, splat);  // x: the arc's turn, w: the target's opacity
    opacity = opacity + (other.w - opacity) * t;
    scale = scale + (other_scale - scale) * t;
    dc = dc + (other_dc - dc) * t;
    q = morph_slerp(q, other_q, other.x, t);
}

void main()
{
    rec_pos = vec4(0.0);
    rec_conic = vec4(0.0);
    rec_color = vec4(0.0);
    int i = int(gl_FragCoord.y) * sizes.x + int(gl_FragCoord.x);
    if (i >= sizes.w) return;
    int drawn = int(fetch(order_tex, i).x);
    int obj = object_of(drawn);
    vec4 o0 = object_texel(obj, 0), o1 = object_texel(obj, 1), o2 = object_texel(obj, 2);
    vec4 eye_hi = object_texel(obj, 3), eye_lo = object_texel(obj, 4);
    vec4 c0 = object_texel(obj, 5), c1 = object_texel(obj, 6), c2 = object_texel(obj, 7);
    vec4 ortho_dir = object_texel(obj, 8);
    int local = drawn - int(ortho_dir.w);
    int splat = int(object_texel(obj, 10).x) + local;  // its data's, shared by instances
    mat3 cam_from_local = mat3(o0.xyz, o1.xyz, o2.xyz);
    float splat_scale = o0.w;
    int degree = int(o2.w), mode = int(eye_hi.w);
    bool sh_only = eye_lo.w > 0.5, ortho = flags.x != 0;

    vec4 p = fetch(pos_tex, splat);
    if (!sl_is_finite3(p.xyz) || !sl_is_finite(p.w)) return;  // NaN: packing found it undrawable
    vec4 q;
    vec3 scale, dc;
    shape_of(shape_tex, splat, q, scale, dc);
    float opacity = p.w;
    vec4 effects = object_texel(obj, 9);
    vec3 centre_local = p.xyz;
    if (effects.w > 0.0) {
        morph_splat(splat, effects.w, opacity, scale, q, dc);
        if (!sl_is_finite(opacity)) return;  // NaN: packing found the target's splat undrawable
        // morph.blend's lerp of the centres, from the source end's
        centre_local = (fetch(morph_centres_tex, splat).xyz - p.xyz) * effects.w + p.xyz;
    }
    if (effects.y > 0.0) {
        centre_local = displaced(int(effects.x), int(effects.y), centre_local, splat);
        vec3 rest = effects.z > 0.5 ? fetch(rest_tex, splat).xyz : p.xyz;
        apply_effects(int(effects.x), int(effects.y), centre_local, rest, local,
                      opacity, scale, dc);
    }
    opacity *= o1.w;

    vec3 rel = (centre_local - eye_hi.xyz) - eye_lo.xyz;
    vec3 t = cam_from_local * rel;
    float depth = -t.z;
    if (!(depth > frame.z) || depth > frame.w) return;

    vec3 conic = vec3(0.0);
    float radius;
    if (mode == 1) {  // point cloud: a fixed-size opaque dot at the centre
        radius = misc.x;
        opacity = 1.0;
    } else {
        mat3 axes = sl_axes_camera(cam_from_local, q, scale * splat_scale);
        vec4 cov = sl_cov2d(axes, sl_jacobian(t, focal_centre.xy, jac_bounds, ortho));
        float lambda_max;
        if (!sl_conic(cov, flags.y != 0, opacity, conic, lambda_max) || !(opacity >= SL_ALPHA_MIN)) return;
        radius = sl_quad_radius(lambda_max, opacity, flags.z != 0);  // flags.z: capped extent
    }
    vec2 centre = sl_project_point(t, focal_centre, ortho);
    if (!sl_is_finite(radius) || !sl_is_finite(centre.x) || !sl_is_finite(centre.y)) return;
    vec3 dir = ortho ? ortho_dir.xyz : rel / length(rel);
    vec3 rgb = sh_colour(splat, dir, degree, dc, sh_only, effects.w);
    float lighting = object_texel(obj, 10).y;
    if (lighting > 0.0) {  // scales 0.5 + SH, so the grade below applies to the lit colour
        vec3 normal = sl_normal_camera(cam_from_local, sl_shortest_axis(q, scale));
        rgb *= sl_light_factor(dc, sl_radiance(sizes.z * OBJECT_TEXELS, t, normal), lighting);
    }
    rgb = sl_grade_color(rgb, mat3(c0.x, c1.x, c2.x, c0.y, c1.y, c2.y, c0.z, c1.z, c2.z),
                         vec3(c0.w, c1.w, c2.w));
    if (flags.w != 0) rgb = sl_srgb_decode(rgb);

    float z_clip = proj_z.x * t.z + proj_z.y, w_clip = proj_z.z * t.z + proj_z.w;
    rec_pos = vec4(centre, clamp(z_clip / w_clip, -1.0, 1.0), radius);
    rec_conic = vec4(conic, opacity);
    rec_color = vec4(rgb, float(mode));
}
