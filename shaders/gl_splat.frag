// Offscreen renderer, stage "draw": Gaussian falloff, premultiplied output.
// Blending is ONE, ONE_MINUS_SRC_ALPHA back to front into RGBA32F.
flat in vec2 v_centre;
flat in vec3 v_conic;
flat in vec4 v_colour;
flat in float v_rank;

uniform vec4 u_tile;

out vec4 frag;

void main()
{
    // pixel centre in frame pixels, top-left origin (the tile is rendered flipped)
    vec2 pix = vec2(u_tile.x + gl_FragCoord.x, u_tile.y + u_tile.w - gl_FragCoord.y);
    float alpha = sl_alpha(pix - v_centre, v_conic, v_colour.a);
    if (alpha < SL_ALPHA_MIN) discard;
    frag = vec4(v_colour.rgb * alpha, alpha);
}
