// Offscreen renderer, early termination: after a front-to-back batch, mark the pixels whose
// transmittance fell below SL_T_STOP (1e-4, INRIA's) in the depth buffer, so the splat
// quads of later batches fail the depth test there before their fragment shader runs.
// Drawn into a depth-only framebuffer over the full tile; kept fragments write depth 0.5.
uniform sampler2D u_colour;  // the tile's colour target: alpha = 1 - T

const float SL_T_STOP = 1.0e-4;  // twin of core/render_constants.py T_STOP

void main()
{
    if (texelFetch(u_colour, ivec2(gl_FragCoord.xy), 0).a <= 1.0 - SL_T_STOP) discard;
#ifdef SL_HOLDOUT
    // the depth buffer holds the holdout's encoded surface depths and the splats lie at
    // their own (gl_splat.vert): a mark at 0 closes the pixel to every one of them
    gl_FragDepth = 0.0;
#endif
}
