// Offscreen renderer, depth pass: narrow each pixel's rank interval [lo, hi] with the
// transmittance measured at its midpoint: alpha reached 0.5 by mid -> hi = mid, else lo = mid + 1.
uniform sampler2D u_bounds;
uniform sampler2D u_trans;

out vec4 frag;

void main()
{
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec2 b = texelFetch(u_bounds, px, 0).xy;
    float mid = floor(0.5 * (b.x + b.y));
    float t = texelFetch(u_trans, px, 0).r;
    frag = t <= 0.5 ? vec4(b.x, mid, 0.0, 0.0) : vec4(mid + 1.0, b.y, 0.0, 0.0);
}
