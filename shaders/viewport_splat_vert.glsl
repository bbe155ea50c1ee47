// Viewport (Blender gpu module), vertex stage: one instanced quad per splat.
// Needs splat_math.glsl before this file; declarations come from GPUShaderCreateInfo
// (addon/blender/viewport/gpu_draw.py). Texel layouts: addon/blender/viewport/packing.py.
//
// gl_InstanceID is the draw position (farthest first); order_tex maps it to the splat.
// Everything is camera-relative: t = cam_from_local * (p - eye), eye split hi + lo.

// Every data texture is sizes.x texels wide (packing.WIDTH).
vec4 fetch(sampler2D tex, int texel)
{
    return texelFetch(tex, ivec2(texel % sizes.x, texel / sizes.x), 0);
}

void cull_vertex()
{
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // outside the clip volume: the quad vanishes
    v_offset = vec2(0.0);
    v_conic = vec3(0.0);
    v_color = vec3(0.0);
    v_opacity = 0.0;
    v_extent = 0.0;
    v_mode = 0;
}

vec3 sh_colour(int splat, vec3 dir, int degree, vec3 dc, bool sh_only)
{
    vec3 rest[15];
    for (int k = 0; k < 15; k++) rest[k] = vec3(0.0);
    int coeffs = (degree + 1) * (degree + 1) - 1;
    if (coeffs > 0 && sizes.y > 0) {
        vec4 tx[12];
        int used = (3 * coeffs + 3) / 4;
        for (int j = 0; j < 12; j++) {
            tx[j] = j < used ? fetch(sh_tex, splat * sizes.y + j) : vec4(0.0);
        }
        for (int k = 0; k < coeffs; k++) {
            int c = 3 * k;
            rest[k] = vec3(tx[c / 4][c % 4], tx[(c + 1) / 4][(c + 1) % 4], tx[(c + 2) / 4][(c + 2) % 4]);
        }
    }
    // "show SH only": the higher bands over grey, without the DC term
    return sl_sh_color(dir, degree, sh_only ? vec3(0.0) : dc, rest);
}

vec3 srgb_to_linear(vec3 c)
{
    vec3 lo = c / 12.92;
    vec3 hi = pow((c + 0.055) / 1.055, vec3(2.4));
    return mix(lo, hi, step(vec3(0.04045), c));
}

void main()
{
    int splat = int(fetch(order_tex, gl_InstanceID).x);
    vec4 p = fetch(pos_tex, splat);
    vec4 q = fetch(shape_tex, 3 * splat);
    vec4 s = fetch(shape_tex, 3 * splat + 1);
    vec4 dc = fetch(shape_tex, 3 * splat + 2);
    int row = int(s.w) * 9;
    vec4 o0 = texelFetch(object_tex, ivec2(row, 0), 0);
    vec4 o1 = texelFetch(object_tex, ivec2(row + 1, 0), 0);
    vec4 o2 = texelFetch(object_tex, ivec2(row + 2, 0), 0);
    vec4 eye_hi = texelFetch(object_tex, ivec2(row + 3, 0), 0);
    vec4 eye_lo = texelFetch(object_tex, ivec2(row + 4, 0), 0);
    vec4 c0 = texelFetch(object_tex, ivec2(row + 5, 0), 0);
    vec4 c1 = texelFetch(object_tex, ivec2(row + 6, 0), 0);
    vec4 c2 = texelFetch(object_tex, ivec2(row + 7, 0), 0);
    vec4 ortho_dir = texelFetch(object_tex, ivec2(row + 8, 0), 0);
    mat3 cam_from_local = mat3(o0.xyz, o1.xyz, o2.xyz);
    float splat_scale = o0.w, opacity = p.w * o1.w;
    int degree = int(o2.w), mode = int(eye_hi.w);
    bool sh_only = eye_lo.w > 0.5, ortho = flags.x != 0;

    if (!sl_is_finite3(p.xyz) || !sl_is_finite3(s.xyz) || !sl_quat_ok(q) || !sl_is_finite(opacity)) {
        cull_vertex();
        return;
    }
    vec3 rel = (p.xyz - eye_hi.xyz) - eye_lo.xyz;
    vec3 t = cam_from_local * rel;
    float depth = -t.z;
    if (!(depth > frame.z) || depth > frame.w) { cull_vertex(); return; }

    vec3 conic = vec3(0.0);
    float radius, extent = 0.0;
    if (mode == 1) {  // point cloud: a fixed-size opaque dot at the centre
        radius = misc.x;
        opacity = 1.0;
    } else {
        mat3 axes = sl_axes_camera(cam_from_local, q, s.xyz * splat_scale);
        vec4 cov = sl_cov2d(axes, sl_jacobian(t, focal_centre.xy, jac_bounds, ortho));
        float lambda_max;
        if (!sl_conic(cov, flags.y != 0, opacity, conic, lambda_max) || !(opacity >= SL_ALPHA_MIN)) {
            cull_vertex();
            return;
        }
        extent = sl_extent_sigma(opacity, flags.z != 0);  // flags.z: capped extent
        radius = extent * sqrt(lambda_max);
    }
    vec2 centre = sl_project_point(t, focal_centre, ortho);
    if (!sl_is_finite(radius) || !sl_is_finite(centre.x) || !sl_is_finite(centre.y)) {
        cull_vertex();
        return;
    }
    vec3 dir = ortho ? ortho_dir.xyz : rel / length(rel);
    vec3 rgb = sh_colour(splat, dir, degree, dc.xyz, sh_only);
    rgb = sl_grade_color(rgb, mat3(c0.x, c1.x, c2.x, c0.y, c1.y, c2.y, c0.z, c1.z, c2.z),
                         vec3(c0.w, c1.w, c2.w));
    if (flags.w != 0) rgb = srgb_to_linear(rgb);

    // pixel corner (y down, top-left origin) -> NDC; depth from the centre, for the depth test
    vec2 offset = corner * radius;
    vec2 pix = centre + offset;
    float z_clip = proj_z.x * t.z + proj_z.y, w_clip = proj_z.z * t.z + proj_z.w;
    gl_Position = vec4(2.0 * pix.x / frame.x - 1.0, 1.0 - 2.0 * pix.y / frame.y,
                       clamp(z_clip / w_clip, -1.0, 1.0), 1.0);
    v_offset = offset;
    v_conic = conic;
    v_color = rgb;
    v_opacity = opacity;
    v_extent = extent;
    v_mode = mode;
}
