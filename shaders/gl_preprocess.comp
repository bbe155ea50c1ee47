// Offscreen renderer, stage "preprocess": one invocation per splat of one object part.
// Projects the splat camera-relative and writes its screen record and view depth at
// u_base + i in the frame-wide arrays (so several objects share one global sort).
// Needs: splat_math.glsl before this file; #version 430 from the loader.
layout(local_size_x = 256) in;

layout(std430, binding = 0) readonly buffer Geom { vec4 geom[]; };  // 3 per splat: pos+opacity, scale, quat wxyz
layout(std430, binding = 1) readonly buffer Dc { float sh_dc[]; };  // 3 per splat
layout(std430, binding = 2) readonly buffer Rest { float sh_rest[]; };  // 3 * u_rest_count per splat
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
uniform bool u_ortho;
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

// float bits -> uint with the same order (negative floats too), for atomicMin/Max
uint ordered_bits(float f)
{
    uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : (u | 0x80000000u);
}

vec3 sh_colour(uint i, vec3 dir)
{
    vec3 dc = vec3(sh_dc[3u * i], sh_dc[3u * i + 1u], sh_dc[3u * i + 2u]);
    vec3 rest[15];
    uint n = uint(min(u_rest_count, 15));
    uint base = i * uint(u_rest_count) * 3u;
    for (uint k = 0u; k < 15u; k++) {
        rest[k] = k < n ? vec3(sh_rest[base + 3u * k], sh_rest[base + 3u * k + 1u],
                               sh_rest[base + 3u * k + 2u]) : vec3(0.0);
    }
    return sl_sh_color(dir, u_sh_degree, dc, rest);
}

void cull(uint g)
{
    rec1[g] = vec4(0.0);
    depth_key_src[g] = uintBitsToFloat(0x7f800000u);  // +inf
}

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    uint g = u_base + i;
    vec4 p = geom[3u * i], s = geom[3u * i + 1u], q = geom[3u * i + 2u];
    float opacity = p.w * u_opacity_scale;
    if (!sl_is_finite3(p.xyz) || !sl_is_finite3(s.xyz) || !sl_quat_ok(q) || !sl_is_finite(opacity)) {
        cull(g);
        return;
    }
    // camera-relative: p - eye exactly in float32 for nearby points (eye split hi + lo)
    vec3 rel = (p.xyz - u_eye_hi) - u_eye_lo;
    vec3 t = u_cam_from_local * rel;
    float depth = -t.z;
    if (!(depth > u_near_far.x) || depth > u_near_far.y) { cull(g); return; }

    mat3 axes = sl_axes_camera(u_cam_from_local, q, s.xyz * u_splat_scale);
    vec4 cov = sl_cov2d(axes, sl_jacobian(t, u_focal_centre.xy, u_jac_bounds, u_ortho));
    vec3 conic;
    float lambda_max;
    if (!sl_conic(cov, u_antialiased, opacity, conic, lambda_max) || !(opacity >= SL_ALPHA_MIN)) {
        cull(g);
        return;
    }
    float radius = sl_quad_radius(lambda_max, opacity, u_capped_extent);
    vec2 centre = sl_project_point(t, u_focal_centre, u_ortho);
    // off-frame quads are culled here so they do not widen the depth-key range
    bool off = any(lessThan(centre + radius, vec2(0.0))) || any(greaterThan(centre - radius, u_frame));
    if (off || !sl_is_finite(radius) || !sl_is_finite(centre.x) || !sl_is_finite(centre.y)) {
        cull(g);
        return;
    }
    vec3 dir = u_ortho ? u_ortho_dir : rel / length(rel);
    vec3 rgb = sl_grade_color(sh_colour(i, dir), u_color_linear, u_color_offset);
    if (!sl_is_finite3(rgb)) { cull(g); return; }
    rec0[g] = vec4(centre, conic.xy);
    rec1[g] = vec4(conic.z, radius, depth, opacity);
    rec2[g] = vec4(rgb, 0.0);
    // Sort on depth minus a per-frame anchor (offset summed in float64 on the CPU): a small
    // object far from the camera keeps its depth differences, which depth itself rounds away.
    float sort_depth = dot(u_depth_axis, p.xyz) + u_sort_offset;
    depth_key_src[g] = sort_depth;
    uint bits = ordered_bits(sort_depth);
    atomicMin(range_bits[0], bits);
    atomicMax(range_bits[1], bits);
    atomicAdd(range_bits[2], 1u);
}
