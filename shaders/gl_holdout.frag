// Offscreen renderer, holdout: the ray through this pixel's centre against the triangle
// (Moeller-Trumbore, edges inclusive, both faces), as core/holdout.py casts it in
// float64. The hit's parameter is the depth itself: perspective rays (a, b, -1) from the
// camera centre, orthographic rays (0, 0, -1) from the image plane, equirect unit rays.
// A hit counts where near < depth <= far; the target (R32F, cleared to +inf) keeps the
// nearest through MIN blending, so no depth buffer and no non-linear z are involved.
flat in vec3 v_p0;
flat in vec3 v_e1;
flat in vec3 v_e2;

uniform vec4 u_focal_centre;  // fx, fy, cx, cy
uniform vec2 u_near_far;
uniform vec4 u_tile;

layout(location = 0) out vec4 frag;

void main()
{
    vec2 pix = gl_FragCoord.xy + u_tile.xy;  // the pixel centre, frame pixels (rows top-down)
    float a = (pix.x - u_focal_centre.z) / u_focal_centre.x;
    float b = (u_focal_centre.w - pix.y) / u_focal_centre.y;
#if SL_CAMERA == 2
    float cb = cos(b);
    vec3 dir = vec3(cb * sin(a), sin(b), -cb * cos(a));
    vec3 s = -v_p0;
#elif SL_CAMERA == 1
    vec3 dir = vec3(0.0, 0.0, -1.0);
    vec3 s = vec3(a, b, 0.0) - v_p0;
#else
    vec3 dir = vec3(a, b, -1.0);
    vec3 s = -v_p0;
#endif
    vec3 p = cross(dir, v_e2);
    float det = dot(v_e1, p);
    float inv = 1.0 / det;
    float u = dot(s, p) * inv;
    vec3 q = cross(s, v_e1);
    float v = dot(dir, q) * inv;
    float t = dot(v_e2, q) * inv;
    if (!(det != 0.0 && u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > u_near_far.x && t > 0.0
          && t <= u_near_far.y))
        discard;
    frag = vec4(t, 0.0, 0.0, 0.0);
}
