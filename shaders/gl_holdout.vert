// Offscreen renderer, holdout (issue 25): the depth of the nearest opaque surface under
// each pixel centre, the measure the splats are sorted by (core/holdout.py).
// One instance per triangle draws a screen-aligned quad over the triangle's screen box;
// the fragment stage (gl_holdout.frag) casts the pixel-centre ray against the triangle
// exactly (Moeller-Trumbore), so the box only has to hold every pixel the triangle can
// hit: perspective, the box of the part in front of the clip start (clipped at it, as the
// reference); orthographic, the three corners' box; equirect, the longitude/latitude box
// of the triangle's bounding cone of directions, the whole tile where that cone is wider
// than a hemisphere or reaches a pole, drawn again one period over (u_shift) for the
// seam. One pixel of slack each side (the exact test decides).
// Needs #define SL_CAMERA (0 perspective, 1 orthographic, 2 equirect).
in vec3 a_v0;  // the triangle's corners in the holdout's local frame (world - origin)
in vec3 a_v1;
in vec3 a_v2;

uniform mat3 u_rot;            // world -> camera rotation
uniform vec3 u_offset;         // the local origin in camera space (float64 on the CPU)
uniform vec4 u_focal_centre;   // fx, fy, cx, cy
uniform vec2 u_near_far;       // a hit counts where near < depth <= far
uniform vec4 u_tile;           // x0, y0, width, height of the tile, frame pixels
uniform float u_shift;         // equirect: this draw's longitude shift in pixels (0, +-period)

flat out vec3 v_p0;  // camera-space corner 0 and the two edges from it
flat out vec3 v_e1;
flat out vec3 v_e2;

const float SL_HALF_PI = 1.5707963267948966;
const vec4 SL_NO_BOX = vec4(1.0, 1.0, 0.0, 0.0);           // x0 > x1: nothing
const vec4 SL_ANY = vec4(-1e30, -1e30, 1e30, 1e30);       // the whole tile

vec4 add_point(vec4 box, vec2 p)
{
    return vec4(min(box.xy, p), max(box.zw, p));
}

#if SL_CAMERA == 2
float angle_between(vec3 a, vec3 b)
{
    return atan(length(cross(a, b)), dot(a, b));
}

vec4 screen_box(vec3 p0, vec3 p1, vec3 p2)
{
    vec3 d = vec3(length(p0), length(p1), length(p2));
    if (!(max(d.x, max(d.y, d.z)) > u_near_far.x)) return SL_NO_BOX;
    if (!(min(d.x, min(d.y, d.z)) > 0.0)) return u_shift == 0.0 ? SL_ANY : SL_NO_BOX;
    vec3 a = p0 / d.x, b = p1 / d.y, c = p2 / d.z;
    vec3 sum = a + b + c;
    float len = length(sum);
    if (!(len > 1e-6)) return u_shift == 0.0 ? SL_ANY : SL_NO_BOX;
    vec3 axis = sum / len;
    float half_angle = max(angle_between(a, axis), max(angle_between(b, axis), angle_between(c, axis)));
    half_angle += 1e-5;
    float lam = atan(axis.x, -axis.z);
    float phi = atan(axis.y, length(axis.xz));
    float fx = u_focal_centre.x, fy = u_focal_centre.y, cx = u_focal_centre.z, cy = u_focal_centre.w;
    bool cone = half_angle < SL_HALF_PI - 1e-3;
    if (!cone || abs(phi) + half_angle >= SL_HALF_PI - 1e-3) {
        if (u_shift != 0.0) return SL_NO_BOX;  // a full-width box needs no seam copy
        float top = cone ? phi + half_angle : SL_HALF_PI;
        float bottom = cone ? phi - half_angle : -SL_HALF_PI;
        return vec4(-1e30, cy - fy * top, 1e30, cy - fy * bottom);
    }
    float dlam = asin(min(1.0, sin(half_angle) / cos(phi)));
    return vec4(cx + fx * (lam - dlam) + u_shift, cy - fy * (phi + half_angle),
                cx + fx * (lam + dlam) + u_shift, cy - fy * (phi - half_angle));
}
#else
vec2 project(vec3 p)
{
#if SL_CAMERA == 1
    return vec2(u_focal_centre.z + u_focal_centre.x * p.x, u_focal_centre.w - u_focal_centre.y * p.y);
#else
    return vec2(u_focal_centre.z + u_focal_centre.x * p.x / -p.z,
                u_focal_centre.w - u_focal_centre.y * p.y / -p.z);
#endif
}

vec4 screen_box(vec3 p0, vec3 p1, vec3 p2)
{
    vec3 depth = -vec3(p0.z, p1.z, p2.z);
    float near = u_near_far.x;
    if (!(max(depth.x, max(depth.y, depth.z)) > near) || min(depth.x, min(depth.y, depth.z)) > u_near_far.y)
        return SL_NO_BOX;
    vec4 box = vec4(1e30, 1e30, -1e30, -1e30);
#if SL_CAMERA == 1
    box = add_point(add_point(add_point(box, project(p0)), project(p1)), project(p2));
#else
    near = max(near, 1e-12);
    vec3 p[3] = vec3[3](p0, p1, p2);
    for (int i = 0; i < 3; i++) {
        int j = i == 2 ? 0 : i + 1;
        float di = depth[i], dj = depth[j];
        if (di >= near) box = add_point(box, project(p[i]));
        if ((di >= near) != (dj >= near)) {  // the edge crosses the clip start: its point there
            vec3 q = p[i] + (near - di) / (dj - di) * (p[j] - p[i]);
            q.z = -near;
            box = add_point(box, project(q));
        }
    }
#endif
    return box;
}
#endif

void main()
{
    vec3 p0 = u_rot * a_v0 + u_offset, p1 = u_rot * a_v1 + u_offset, p2 = u_rot * a_v2 + u_offset;
    v_p0 = p0;
    v_e1 = p1 - p0;
    v_e2 = p2 - p0;
    vec4 box = screen_box(p0, p1, p2);
    vec2 lo = max(box.xy - 1.0, u_tile.xy), hi = min(box.zw + 1.0, u_tile.xy + u_tile.zw);
    if (!(lo.x <= hi.x && lo.y <= hi.y)) {  // NaN boxes land here too: nothing drawn
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
        return;
    }
    vec2 corner = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1));
    vec2 pix = mix(lo, hi, corner);
    // rows top-down as the splat targets' (gl_splat.vert): the frame's top row is GL's row 0
    vec2 ndc = (pix - u_tile.xy) / u_tile.zw * 2.0 - 1.0;
    gl_Position = vec4(ndc, 0.0, 1.0);
}
