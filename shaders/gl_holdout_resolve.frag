// Offscreen renderer, holdout: the tile's surface depth map (gl_holdout.frag, +inf where
// none) into the tile's depth buffer, encoded as the splats' centre depths are
// (gl_splat.vert): enc(h) = SL_ENC_BASE + (h - lo) * scale, clamped to [0, 1] (+inf: 1,
// the clear). Drawn over the whole tile with the depth test ALWAYS.
uniform sampler2D u_holdout;
uniform vec2 u_holdout_enc;  // lo, scale

const float SL_ENC_BASE = 0.0625;

void main()
{
    float h = texelFetch(u_holdout, ivec2(gl_FragCoord.xy), 0).r;
    gl_FragDepth = clamp(SL_ENC_BASE + (h - u_holdout_enc.x) * u_holdout_enc.y, 0.0, 1.0);
}
