// Offscreen renderer, depth pass: narrow each pixel's rank interval [lo, hi] with the
// transmittance at its 8 probes: alpha reached 0.5 by m_j -> hi <= m_j, else lo >= m_j + 1.
uniform sampler2D u_bounds;
uniform sampler2D u_trans_lo;
uniform sampler2D u_trans_hi;

out vec4 frag;

void main()
{
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec2 b = texelFetch(u_bounds, px, 0).xy;
    vec4 t0 = texelFetch(u_trans_lo, px, 0), t1 = texelFetch(u_trans_hi, px, 0);
    float t[8] = float[8](t0.x, t0.y, t0.z, t0.w, t1.x, t1.y, t1.z, t1.w);
    float lo = b.x, hi = b.y;
    for (uint j = 0u; j < 8u; j++) {
        float m = float(depth_probe(b, j + 1u));
        if (t[j] <= 0.5) hi = min(hi, m); else lo = max(lo, m + 1.0);
    }
    frag = vec4(lo, hi, 0.0, 0.0);
}
