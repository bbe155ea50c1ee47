// Offscreen renderer, depth pass (one search step): for each of the pixel's 8 probe ranks
// m_j, the transmittance of the splats with front-to-back rank <= m_j. Blend ZERO,
// ONE_MINUS_SRC_COLOR into targets cleared to 1 multiplies each channel by (1 - output).
flat in vec2 v_centre;
flat in vec3 v_conic;
flat in vec4 v_colour;
flat in float v_rank;

uniform vec4 u_tile;
uniform sampler2D u_bounds;  // per pixel: lo, hi rank of the search interval

layout(location = 0) out vec4 probe_lo;  // probes 1..4
layout(location = 1) out vec4 probe_hi;  // probes 5..8

void main()
{
    vec2 b = texelFetch(u_bounds, ivec2(gl_FragCoord.xy), 0).xy;
    uint rank = uint(v_rank);
    if (b.x >= b.y || rank > depth_probe(b, 8u)) discard;  // converged, or beyond every probe
    vec2 pix = vec2(u_tile.x + gl_FragCoord.x, u_tile.y + u_tile.w - gl_FragCoord.y);
    float alpha = sl_alpha(pix - v_centre, v_conic, v_colour.a);
    if (alpha < SL_ALPHA_MIN) discard;
    probe_lo = vec4(rank <= depth_probe(b, 1u) ? alpha : 0.0, rank <= depth_probe(b, 2u) ? alpha : 0.0,
                    rank <= depth_probe(b, 3u) ? alpha : 0.0, rank <= depth_probe(b, 4u) ? alpha : 0.0);
    probe_hi = vec4(rank <= depth_probe(b, 5u) ? alpha : 0.0, rank <= depth_probe(b, 6u) ? alpha : 0.0,
                    rank <= depth_probe(b, 7u) ? alpha : 0.0, alpha);
}
