// Offscreen renderer, depth pass: starting interval per pixel. A pixel whose composited
// alpha stays below 0.5 (with a margin far above float32 rounding of the two blends) can
// never reach 0.5 and starts converged at "never" (rank = visible count), so the search
// steps skip its fragments.
uniform sampler2D u_colour;  // the colour pass of this tile (same orientation)
uniform float u_visible_f;
uniform float u_alpha_floor;  // background alpha, removed before the test

out vec4 frag;

void main()
{
    float a = texelFetch(u_colour, ivec2(gl_FragCoord.xy), 0).a;
    float splat_alpha = (a - u_alpha_floor) / max(1.0 - u_alpha_floor, 1e-6);
    frag = splat_alpha < 0.499 ? vec4(u_visible_f, u_visible_f, 0.0, 0.0) : vec4(0.0, u_visible_f, 0.0, 0.0);
}
