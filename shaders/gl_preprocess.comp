// Offscreen renderer, stage "preprocess": one invocation per splat of one object part.
// Projects the splat camera-relative and writes its screen record and view depth at
// u_base + i in the frame-wide arrays (so several objects share one global sort).
// Equirect cameras: depth is the distance, and each splat owns two more slots,
// u_base + i + u_copy_stride (drawn one longitude period to the right) and
// u_base + i + 2 u_copy_stride (one to the left), used where its quad crosses the seam.
// Needs: splat_math.glsl before this file; #version 430 from the loader.
layout(local_size_x = 256) in;

layout(std430, binding = 0) readonly buffer Geom { vec4 geom[]; };  // 4 per splat: pos+opacity, scale, quat wxyz, SH DC
// per splat, its u_rest_count coefficients in groups of four (3 vec4 a group: r g b r | g b
// r g | b r g b), the last group zero-padded (upload.py pack_rest)
layout(std430, binding = 2) readonly buffer Rest { vec4 sh_rest[]; };
layout(std430, binding = 3) writeonly buffer Rec0 { vec4 rec0[]; };  // centre u, v; conic A, B
layout(std430, binding = 4) writeonly buffer Rec1 { vec4 rec1[]; };  // conic C, radius, depth, opacity
layout(std430, binding = 5) writeonly buffer Rec2 { vec4 rec2[]; };  // rgb, unused
layout(std430, binding = 6) writeonly buffer Depth { float depth_key_src[]; };  // +inf when culled
layout(std430, binding = 7) buffer Range { uint range_bits[3]; };  // ordered min, max depth bits; visible count

uniform uint u_count;
uniform uint u_base;
uniform mat3 u_cam_from_local;   // camera rotation * object linear part (float64 on the CPU)
uniform vec3 u_eye_hi;           // camera position in the object's frame, split in two floats
uniform vec3 u_eye_lo;
uniform vec4 u_focal_centre;     // fx, fy, cx, cy
uniform vec4 u_jac_bounds;
uniform vec2 u_frame;            // width, height
uniform vec2 u_near_far;
uniform vec3 u_ortho_dir;        // ortho: the camera's forward axis in the object's frame
uniform vec3 u_depth_axis;       // depth = dot(u_depth_axis, p) + u_sort_offset - frame anchor
uniform float u_sort_offset;
uniform float u_splat_scale;
uniform float u_opacity_scale;
uniform int u_sh_degree;
uniform int u_rest_count;        // coefficients per channel stored in Rest
uniform mat3 u_color_linear;
uniform vec3 u_color_offset;
uniform bool u_antialiased;
uniform bool u_capped_extent;   // quads cut at 3 sigma (speed), else the 1/255 contour
uniform float u_lat_limit;       // equirect: latitude clamp of J (radians)
uniform float u_period;          // equirect: pixels per full turn of longitude
uniform uint u_copy_stride;      // equirect: splats in the frame (slot stride of the copies); else 0
uniform bool u_track_range;      // gather range_bits (the GPU sort's keys need them)
uniform vec2 u_lens;             // depth of field: aperture radius, 1 / focus distance; (0, 0) = off

// The camera's projection (SL_CAMERA: 0 perspective, 1 orthographic, 2 equirect) and
// whether it has depth of field (SL_DOF) are constants, one program per combination a
// scene uses (frame.py): llvmpipe runs both sides of a branch under a lane mask, so as
// uniforms they cost every splat the equirect and DOF paths too (34 ms against 25 on the
// final-frame bench's 500,000 splats).
const bool sl_ortho = SL_CAMERA == 1;
const bool sl_equirect = SL_CAMERA == 2;

// float bits -> uint with the same order (negative floats too), for atomicMin/Max
uint ordered_bits(float f)
{
    uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : (u | 0x80000000u);
}

// the four SH coefficients (rgb each) held in the three vec4 at q
void rest_group(uint q, out vec3 k0, out vec3 k1, out vec3 k2, out vec3 k3)
{
    vec4 a = sh_rest[q], b = sh_rest[q + 1u], c = sh_rest[q + 2u];
    k0 = a.xyz;
    k1 = vec3(a.w, b.xy);
    k2 = vec3(b.zw, c.x);
    k3 = c.yzw;
}

// sl_sh_color with the coefficients loaded a group at a time, only for the bands drawn:
// vec4 loads, because on llvmpipe every scalar load is its own per-lane gather (at
// degree 2 the 24 of them took a quarter of the preprocess, 500,000 splats at 1080p), and
// no 15-entry local array, which cost loads of all 15. A band the buffer lacks adds
// nothing, as there.
vec3 sh_colour(uint i, vec4 dc, vec3 dir)
{
    vec3 result = SL_SH_C0 * dc.xyz;
    uint have = uint(u_rest_count);
    if (u_sh_degree < 1 || have < 3u)
        return result + 0.5;
    uint q = i * ((have + 3u) / 4u) * 3u;
    vec3 k0, k1, k2, k3, k4, k5, k6, k7;
    rest_group(q, k0, k1, k2, k3);
    result += sl_sh_band1(dir, k0, k1, k2);
    if (u_sh_degree < 2 || have < 8u)
        return result + 0.5;
    rest_group(q + 3u, k4, k5, k6, k7);
    result += sl_sh_band2(dir, k3, k4, k5, k6, k7);
    if (u_sh_degree < 3 || have < 15u)
        return result + 0.5;
    vec3 k8, k9, k10, k11, k12, k13, k14, pad;
    rest_group(q + 6u, k8, k9, k10, k11);
    rest_group(q + 9u, k12, k13, k14, pad);
    result += sl_sh_band3(dir, k8, k9, k10, k11, k12, k13, k14);
    return result + 0.5;
}

void cull_slot(uint g)
{
    rec1[g] = vec4(0.0);
    depth_key_src[g] = uintBitsToFloat(0x7f800000u);  // +inf
}

void cull(uint g)
{
    cull_slot(g);
    if (sl_equirect) {
        cull_slot(g + u_copy_stride);
        cull_slot(g + 2u * u_copy_stride);
    }
}

bool on_frame(vec2 centre, float radius)
{
    return !(any(lessThan(centre + radius, vec2(0.0))) || any(greaterThan(centre - radius, u_frame)));
}

// One record, or a culled slot where this position of the splat misses the frame.
void emit(uint g, vec2 centre, vec3 conic, float radius, float depth, float opacity, vec3 rgb,
          float sort_depth)
{
    if (!on_frame(centre, radius)) { cull_slot(g); return; }
    rec0[g] = vec4(centre, conic.xy);
    rec1[g] = vec4(conic.z, radius, depth, opacity);
    rec2[g] = vec4(rgb, 0.0);
    depth_key_src[g] = sort_depth;
    if (!u_track_range) return;
    uint bits = ordered_bits(sort_depth);
    atomicMin(range_bits[0], bits);
    atomicMax(range_bits[1], bits);
    atomicAdd(range_bits[2], 1u);
}

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    uint g = u_base + i;
    vec4 p = geom[4u * i], s = geom[4u * i + 1u], q = geom[4u * i + 2u];
    float opacity = p.w * u_opacity_scale;
    if (!sl_is_finite3(p.xyz) || !sl_is_finite3(s.xyz) || !sl_quat_ok(q) || !sl_is_finite(opacity)) {
        cull(g);
        return;
    }
    // camera-relative: p - eye exactly in float32 for nearby points (eye split hi + lo)
    vec3 rel = (p.xyz - u_eye_hi) - u_eye_lo;
    vec3 t = u_cam_from_local * rel;
    float depth = sl_equirect ? length(t) : -t.z;
    if (!(depth > u_near_far.x) || depth > u_near_far.y) { cull(g); return; }

    mat3 axes = sl_axes_camera(u_cam_from_local, q, s.xyz * u_splat_scale);
    mat3x2 jac = sl_equirect ? sl_equirect_jacobian(t, u_focal_centre.xy, u_lat_limit)
                            : sl_jacobian(t, u_focal_centre.xy, u_jac_bounds, sl_ortho);
    vec4 cov = sl_cov2d(axes, jac);
#if SL_DOF
    if (u_lens.x > 0.0) sl_defocus(cov, depth, u_focal_centre.xy, u_lens, u_antialiased, opacity);
#endif
    vec3 conic;
    float lambda_max;
    if (!sl_conic(cov, u_antialiased, opacity, conic, lambda_max) || !(opacity >= SL_ALPHA_MIN)) {
        cull(g);
        return;
    }
    float radius = sl_quad_radius(lambda_max, opacity, u_capped_extent);
    vec2 centre = sl_equirect ? sl_equirect_point(t, u_focal_centre)
                             : sl_project_point(t, u_focal_centre, sl_ortho);
    vec2 turn = vec2(u_period, 0.0);
    // off-frame quads are culled here so they do not widen the depth-key range
    bool on = on_frame(centre, radius) || (sl_equirect
        && (on_frame(centre + turn, radius) || on_frame(centre - turn, radius)));
    if (!on || !sl_is_finite(radius) || !sl_is_finite(centre.x) || !sl_is_finite(centre.y)) {
        cull(g);
        return;
    }
    vec3 dir = sl_ortho ? u_ortho_dir : rel / length(rel);
    vec3 rgb = sl_grade_color(sh_colour(i, geom[4u * i + 3u], dir), u_color_linear, u_color_offset);
    if (!sl_is_finite3(rgb)) { cull(g); return; }
    // Sort on depth minus a per-frame anchor (offset summed in float64 on the CPU): a small
    // object far from the camera keeps its depth differences, which depth itself rounds away.
    // Equirect: the distance itself (no view axis to take a linear depth along).
    float sort_depth = sl_equirect ? depth : dot(u_depth_axis, p.xyz) + u_sort_offset;
    emit(g, centre, conic, radius, depth, opacity, rgb, sort_depth);
    if (sl_equirect) {
        emit(g + u_copy_stride, centre + turn, conic, radius, depth, opacity, rgb, sort_depth);
        emit(g + 2u * u_copy_stride, centre - turn, conic, radius, depth, opacity, rgb, sort_depth);
    }
}
