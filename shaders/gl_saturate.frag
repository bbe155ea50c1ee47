// Offscreen renderer, early termination: after a front-to-back batch, mark the pixels whose
// transmittance fell below SL_T_STOP (1e-4, INRIA's) in the depth buffer, so the splat
// quads of later batches fail the depth test there before their fragment shader runs.
// Drawn into a depth-only framebuffer over the full tile; kept fragments write depth 0.5.
uniform sampler2D u_colour;  // the tile's colour target: alpha = 1 - T

const float SL_T_STOP = 1.0e-4;  // twin of core/reference.py T_STOP

#ifdef SL_HOLDOUT
// Holdout (issue 25): also mark where the surface (gl_holdout.frag) lies at or in front of
// every splat still to be drawn (u_z_next: the least centre depth of the remaining
// batches): their fragments there would all be dropped. u_saturate false (early
// termination off): marked only so.
uniform sampler2D u_holdout;
uniform float u_z_next;
uniform bool u_saturate;
#endif

void main()
{
#ifdef SL_HOLDOUT
    ivec2 p = ivec2(gl_FragCoord.xy);
    bool open = (!u_saturate || texelFetch(u_colour, p, 0).a <= 1.0 - SL_T_STOP)
        && !(texelFetch(u_holdout, p, 0).r <= u_z_next);
    if (open) discard;
#else
    if (texelFetch(u_colour, ivec2(gl_FragCoord.xy), 0).a <= 1.0 - SL_T_STOP) discard;
#endif
}
