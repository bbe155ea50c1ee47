// Offscreen renderer, depth pass (one bisection step): transmittance of the splats whose
// front-to-back rank is <= this pixel's midpoint rank. Blend ZERO, ONE_MINUS_SRC_ALPHA
// into a target cleared to 1 multiplies T by (1 - alpha) for each of them.
flat in vec2 v_centre;
flat in vec3 v_conic;
flat in vec4 v_colour;
flat in float v_rank;

uniform vec4 u_tile;
uniform sampler2D u_bounds;  // per pixel: lo, hi rank of the search interval

out vec4 frag;

void main()
{
    vec2 b = texelFetch(u_bounds, ivec2(gl_FragCoord.xy), 0).xy;
    if (v_rank > floor(0.5 * (b.x + b.y))) discard;
    vec2 pix = vec2(u_tile.x + gl_FragCoord.x, u_tile.y + u_tile.w - gl_FragCoord.y);
    float alpha = sl_alpha(pix - v_centre, v_conic, v_colour.a);
    if (alpha < SL_ALPHA_MIN) discard;
    frag = vec4(0.0, 0.0, 0.0, alpha);
}
