// Offscreen renderer, stage "draw": Gaussian falloff, premultiplied output, composited
// front to back ("under": blend ONE_MINUS_DST_ALPHA, ONE into RGBA32F cleared to 0), so
// dst.a is the accumulated alpha 1 - T and each splat adds T alpha (rgb, 1).
// Location 1 (the Z pass, where attached) adds T alpha (depth, 0, 0, 1): its red channel
// ends as sum of T_i alpha_i z_i, the numerator of the alpha-weighted depth.
noperspective in vec2 v_w;
flat in vec4 v_colour;
flat in float v_depth;

layout(location = 0) out vec4 frag;
layout(location = 1) out vec4 frag_z;

void main()
{
    // v_w was interpolated at this pixel's centre: sl_alpha there, one dot product
    float alpha = sl_alpha_whitened(v_w, v_colour.a);
    // below 1/255 the splat adds exactly nothing: a zero source under "under" blending
    // leaves the target as it was (dst + 0), the same pixels as a discard would, and on
    // llvmpipe ~15% cheaper per frame than a discard (no per-fragment kill mask)
    alpha = alpha < SL_ALPHA_MIN ? 0.0 : alpha;
    frag = vec4(v_colour.rgb * alpha, alpha);
    frag_z = vec4(v_depth * alpha, 0.0, 0.0, alpha);
}
