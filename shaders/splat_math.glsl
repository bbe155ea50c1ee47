// Splatline: the splat math, written once, shared by both GPU paths.
//
// Plain GLSL 3.30-compatible functions and constants: no #version, no in/out/uniform/buffer
// declarations, no SSBOs, no compute builtins. The offscreen renderer (moderngl, addon/gl)
// and the viewport (Blender gpu module) prepend/append their own stage code.
// Semantics: ../docs and DESIGN.md "Rendering semantics" (INRIA forward pass).
//
// Conventions: camera space is Blender's (looks down -z, +y up). Image space is in pixels,
// origin top-left, y down, pixel centres at +0.5: u = cx + fx*x/-z, v = cy - fy*y/-z.

const float SL_SH_C0 = 0.28209479177387814;
const float SL_SH_C1 = 0.4886025119029199;
const float SL_SH_C2_0 = 1.0925484305920792;
const float SL_SH_C2_1 = -1.0925484305920792;
const float SL_SH_C2_2 = 0.31539156525252005;
const float SL_SH_C2_3 = -1.0925484305920792;
const float SL_SH_C2_4 = 0.5462742152960396;
const float SL_SH_C3_0 = -0.5900435899266435;
const float SL_SH_C3_1 = 2.890611442640554;
const float SL_SH_C3_2 = -0.4570457994644658;
const float SL_SH_C3_3 = 0.3731763325901154;
const float SL_SH_C3_4 = -0.4570457994644658;
const float SL_SH_C3_5 = 1.445305721320277;
const float SL_SH_C3_6 = -0.5900435899266435;

// The next three are twins of core/render_constants.py (LOW_PASS, ALPHA_MIN, MAX_ALPHA).
const float SL_LOWPASS = 0.3;            // px^2 added to the 2D covariance diagonal
const float SL_ALPHA_MIN = 1.0 / 255.0;  // fragments below this are dropped
const float SL_ALPHA_MAX = 0.99;
// A projected axis longer than this many pixels is shortened to it. On any frame up to
// 16384 px the Gaussian is then flat to within exp(-0.5*(2.4e4/1e7)^2) ~ 1 - 3e-6, and the
// 2D covariance stays far from float32 overflow (scales 1e6 at depth 0.2 would reach 1e36).
const float SL_MAX_AXIS_PX = 1.0e7;

bool sl_is_finite(float x) { return !(isnan(x) || isinf(x)); }
bool sl_is_finite3(vec3 v) { return sl_is_finite(v.x) && sl_is_finite(v.y) && sl_is_finite(v.z); }
bool sl_is_finite4(vec4 v) { return sl_is_finite3(v.xyz) && sl_is_finite(v.w); }

// A quaternion the renderers accept: finite and not zero (others are culled, as in
// core/preprocess.py).
bool sl_quat_ok(vec4 q)
{
    return sl_is_finite4(q) && max(max(abs(q.x), abs(q.y)), max(abs(q.z), abs(q.w))) > 0.0;
}

// Rotation matrix (columns) of a quaternion (w, x, y, z). Not necessarily normalized:
// it is rescaled by its largest component first so tiny quaternions do not underflow.
// Callers cull quaternions failing sl_quat_ok; a zero one gives the identity here.
mat3 sl_quat_to_mat(vec4 q)
{
    float m = max(max(abs(q.x), abs(q.y)), max(abs(q.z), abs(q.w)));
    if (!(m > 0.0)) return mat3(1.0);
    q /= m;
    q *= inversesqrt(dot(q, q));
    float w = q.x, x = q.y, y = q.z, z = q.w;
    return mat3(
        vec3(1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z), 2.0 * (x * z - w * y)),
        vec3(2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z + w * x)),
        vec3(2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y)));
}

// The splat's principal axes in camera space, each scaled by its linear scale:
// Sigma_cam = A A^T with A = cam_from_local * R * diag(scale). cam_from_local may hold
// the object's own (non-uniform) scale.
mat3 sl_axes_camera(mat3 cam_from_local, vec4 quat_wxyz, vec3 scale)
{
    mat3 r = cam_from_local * sl_quat_to_mat(quat_wxyz);
    return mat3(r[0] * scale.x, r[1] * scale.y, r[2] * scale.z);
}

// Pixel position of a camera-space point (perspective or orthographic).
vec2 sl_project_point(vec3 t, vec4 focal_centre, bool ortho)
{
    vec2 f = focal_centre.xy, c = focal_centre.zw;
    if (ortho) return vec2(c.x + f.x * t.x, c.y - f.y * t.y);
    float d = -t.z;
    return vec2(c.x + f.x * t.x / d, c.y - f.y * t.y / d);
}

// Jacobian d(u, v)/d(x, y, z) at camera-space point t (mat3x2: 3 columns, 2 rows).
// Perspective: t.xy / -z is clamped to bounds (xmin, ymin, xmax, ymax: the frame plus a
// 15% margin, core/preprocess.j_clamp_bounds, passed in as a uniform) here only, never
// for the centre itself.
mat3x2 sl_jacobian(vec3 t, vec2 focal, vec4 bounds, bool ortho)
{
    if (ortho) return mat3x2(vec2(focal.x, 0.0), vec2(0.0, -focal.y), vec2(0.0));
    float d = -t.z;
    vec2 txy = clamp(t.xy / d, bounds.xy, bounds.zw);
    return mat3x2(
        vec2(focal.x / d, 0.0),
        vec2(0.0, -focal.y / d),
        vec2(focal.x * txy.x / d, -focal.y * txy.y / d));
}

// Equirectangular panorama (twin of core/equirect.py): longitude atan2(x, -z), latitude
// atan2(y, hypot(x, z)); u = cx + fx * longitude, v = cy - fy * latitude.
vec2 sl_equirect_point(vec3 t, vec4 focal_centre)
{
    float lon = atan(t.x, -t.z), lat = atan(t.y, length(t.xz));
    return vec2(focal_centre.z + focal_centre.x * lon, focal_centre.w - focal_centre.y * lat);
}

// d(u, v)/d(x, y, z) of the equirect map at the centre's longitude, with its latitude
// clamped to +-lat_limit (90 deg minus half a pixel row): finite through the poles.
mat3x2 sl_equirect_jacobian(vec3 t, vec2 focal, float lat_limit)
{
    float lon = atan(t.x, -t.z);
    float lat = clamp(atan(t.y, length(t.xz)), -lat_limit, lat_limit);
    float r = length(t), cl = cos(lon), sl = sin(lon), cp = cos(lat), sp = sin(lat);
    return mat3x2(
        vec2(focal.x * cl / (r * cp), focal.y * sp * sl / r),
        vec2(0.0, -focal.y * cp / r),
        vec2(focal.x * sl / (r * cp), -focal.y * sp * cl / r));
}

// Depth of field (twin of core/dof.py widen): adds the circle of confusion's variance
// (f R (1/depth - 1/F))^2 / 4 per axis to sl_cov2d's result (before the low-pass) and
// scales opacity to keep the splat's integral. lens = (R, 1/F); R = 0: no DOF.
void sl_defocus(inout vec4 cov, float depth, vec2 focal, vec2 lens, bool antialiased,
                inout float opacity)
{
    float k = lens.x * (1.0 / depth - lens.y);
    vec2 v = 0.25 * (focal * k) * (focal * k);
    if (!(v.x > 0.0 || v.y > 0.0)) return;  // in focus: exactly as without DOF
    float a = cov.x + v.x, c = cov.z + v.y;
    float det = cov.w + v.x * cov.z + v.y * cov.x + v.x * v.y;
    float before = cov.w + SL_LOWPASS * (cov.x + cov.z) + SL_LOWPASS * SL_LOWPASS;
    float after = det + SL_LOWPASS * (a + c) + SL_LOWPASS * SL_LOWPASS;
    opacity *= antialiased ? sqrt(cov.w / det) : sqrt(before / after);
    cov = vec4(a, cov.y, c, det);
}

// 2D covariance (a, b, c) = [[a, b], [b, c]] before the low-pass, and its determinant in w.
// Built from the projected axes m_k = J * axis_k: Sigma' = sum m_k m_k^T, and
// det by Cauchy-Binet (sum of squared 2x2 minors), which never cancels for needles/discs.
vec4 sl_cov2d(mat3 axes_cam, mat3x2 jac)
{
    vec2 m0 = jac * axes_cam[0], m1 = jac * axes_cam[1], m2 = jac * axes_cam[2];
    float l0 = length(m0), l1 = length(m1), l2 = length(m2);
    if (l0 > SL_MAX_AXIS_PX) m0 *= SL_MAX_AXIS_PX / l0;
    if (l1 > SL_MAX_AXIS_PX) m1 *= SL_MAX_AXIS_PX / l1;
    if (l2 > SL_MAX_AXIS_PX) m2 *= SL_MAX_AXIS_PX / l2;
    float a = m0.x * m0.x + m1.x * m1.x + m2.x * m2.x;
    float b = m0.x * m0.y + m1.x * m1.y + m2.x * m2.y;
    float c = m0.y * m0.y + m1.y * m1.y + m2.y * m2.y;
    float k01 = m0.x * m1.y - m1.x * m0.y;
    float k02 = m0.x * m2.y - m2.x * m0.y;
    float k12 = m1.x * m2.y - m2.x * m1.y;
    return vec4(a, b, c, k01 * k01 + k02 * k02 + k12 * k12);
}

// Low-pass filter, conic and largest eigenvalue. cov is sl_cov2d's result.
// Returns false where the splat must be culled (det <= 0 or non-finite).
// opacity is multiplied by gsplat's compensation sqrt(det/det_lowpass) when antialiased.
bool sl_conic(vec4 cov, bool antialiased, inout float opacity, out vec3 conic, out float lambda_max)
{
    float a = cov.x + SL_LOWPASS, b = cov.y, c = cov.z + SL_LOWPASS;
    // det(S + 0.3 I) = det(S) + 0.3 tr(S) + 0.09: a sum of non-negative terms.
    float det = cov.w + SL_LOWPASS * (cov.x + cov.z) + SL_LOWPASS * SL_LOWPASS;
    conic = vec3(0.0);
    lambda_max = 0.0;
    if (!(det > 0.0) || !sl_is_finite(det) || !sl_is_finite3(cov.xyz)) return false;
    if (antialiased) opacity *= sqrt(max(cov.w, 0.0) / det);
    conic = vec3(c, -b, a) / det;
    float mid = 0.5 * (a + c);
    // mid^2 - det rewritten as ((a-c)/2)^2 + b^2: no cancellation for round splats.
    float h = 0.5 * (a - c);
    lambda_max = mid + sqrt(max(0.1, h * h + b * b));
    return sl_is_finite3(conic) && sl_is_finite(lambda_max);
}

// Quad half-extent in standard deviations: sqrt(2 ln(255 o)), the radius where
// o * exp(-r^2/2) falls to 1/255, so the quad holds the exact footprint (3.33 at o = 1).
// capped (a speed setting): no more than 3, dropping the ring of alpha < 0.011 beyond.
// Twin of core/preprocess.py extent_sigmas.
float sl_extent_sigma(float opacity, bool capped)
{
    float cut = sqrt(2.0 * log(max(255.0 * opacity, 1.0)));
    return capped ? min(3.0, cut) : cut;
}

// Half-size in pixels of the screen-aligned square quad.
float sl_quad_radius(float lambda_max, float opacity, bool capped)
{
    return sl_extent_sigma(opacity, capped) * sqrt(lambda_max);
}

// View-dependent colour, band by band: each returns one band's sum over its coefficients
// (c_k: higher coefficient k for r, g, b). dir: unit vector from the camera to the
// centre, in the splat object's local frame. A caller that loads coefficients itself
// (gl_preprocess.comp) calls only the bands it has; sl_sh_color takes them from an array.
vec3 sl_sh_band1(vec3 dir, vec3 c0, vec3 c1, vec3 c2)
{
    return -SL_SH_C1 * dir.y * c0 + SL_SH_C1 * dir.z * c1 - SL_SH_C1 * dir.x * c2;
}

vec3 sl_sh_band2(vec3 dir, vec3 c3, vec3 c4, vec3 c5, vec3 c6, vec3 c7)
{
    float x = dir.x, y = dir.y, z = dir.z;
    float xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z, xz = x * z;
    return SL_SH_C2_0 * xy * c3 + SL_SH_C2_1 * yz * c4 + SL_SH_C2_2 * (2.0 * zz - xx - yy) * c5
        + SL_SH_C2_3 * xz * c6 + SL_SH_C2_4 * (xx - yy) * c7;
}

vec3 sl_sh_band3(vec3 dir, vec3 c8, vec3 c9, vec3 c10, vec3 c11, vec3 c12, vec3 c13, vec3 c14)
{
    float x = dir.x, y = dir.y, z = dir.z;
    float xx = x * x, yy = y * y, zz = z * z, xy = x * y;
    return SL_SH_C3_0 * y * (3.0 * xx - yy) * c8
        + SL_SH_C3_1 * xy * z * c9
        + SL_SH_C3_2 * y * (4.0 * zz - xx - yy) * c10
        + SL_SH_C3_3 * z * (2.0 * zz - 3.0 * xx - 3.0 * yy) * c11
        + SL_SH_C3_4 * x * (4.0 * zz - xx - yy) * c12
        + SL_SH_C3_5 * z * (xx - yy) * c13
        + SL_SH_C3_6 * x * (xx - 3.0 * yy) * c14;
}

// View-dependent colour before the clamp: C0*dc + bands 1..degree + 0.5.
// rest[k]: higher coefficient k (k = 0..14) for r, g, b; only the first (deg+1)^2-1 are read.
vec3 sl_sh_color(vec3 dir, int degree, vec3 dc, vec3 rest[15])
{
    vec3 result = SL_SH_C0 * dc;
    if (degree > 0)
        result += sl_sh_band1(dir, rest[0], rest[1], rest[2]);
    if (degree > 1)
        result += sl_sh_band2(dir, rest[3], rest[4], rest[5], rest[6], rest[7]);
    if (degree > 2)
        result += sl_sh_band3(dir, rest[8], rest[9], rest[10], rest[11], rest[12], rest[13], rest[14]);
    return result + 0.5;
}

// The object's colour matrix (3x3 + offset, applied after +0.5), then the clamp at 0.
vec3 sl_grade_color(vec3 sh_color, mat3 color_linear, vec3 color_offset)
{
    return max(color_linear * sh_color + color_offset, vec3(0.0));
}

// The conic's quadratic form as a squared length: d^T conic d = |w|^2 with w = U d, U the
// upper-triangular Cholesky factor of the conic (conic = U^T U). w is affine in the pixel
// position, so the rasterizer can interpolate it from a quad's corners and a fragment is
// left with one dot product; on llvmpipe a final frame takes 0.8x the time it did.
// U's second row is sqrt(det / A): det carries the same float32 cancellation for a
// needle as the three-term form does. A valid conic has A > 0 (the low-pass keeps the
// covariance finite); the guard keeps a degenerate one from turning into NaN.
vec2 sl_whiten(vec2 d, vec3 conic)
{
    float root_a = sqrt(max(conic.x, 1e-30));
    float schur = max(conic.z - conic.y * conic.y / max(conic.x, 1e-30), 0.0);
    return vec2(root_a * d.x + conic.y / root_a * d.y, sqrt(schur) * d.y);
}

// sl_alpha at a whitened offset w = sl_whiten(d, conic).
float sl_alpha_whitened(vec2 w, float opacity)
{
    return min(SL_ALPHA_MAX, opacity * exp(-0.5 * dot(w, w)));
}

// Fragment alpha at offset d = pixel centre - splat centre (pixels):
// min(0.99, o * exp(-1/2 d^T conic d)). The caller drops results below SL_ALPHA_MIN.
float sl_alpha(vec2 d, vec3 conic, float opacity)
{
    float power = conic.x * d.x * d.x + 2.0 * conic.y * d.x * d.y + conic.z * d.y * d.y;
    return min(SL_ALPHA_MAX, opacity * exp(-0.5 * max(power, 0.0)));
}

const float SL_SRGB_A = 0.055;
const float SL_SRGB_KNEE = 0.04045;  // twins of core/colorspace.py

// display sRGB to scene-linear: colorspace.srgb_to_linear's float32 steps, in its order
// (the knee exclusive), so the two differ only by the power's rounding
vec3 sl_srgb_decode(vec3 x)
{
    vec3 high = pow((x + SL_SRGB_A) * (1.0 / (1.0 + SL_SRGB_A)), vec3(2.4));
    return mix(x * (1.0 / 12.92), high, greaterThan(x, vec3(SL_SRGB_KNEE)));
}
