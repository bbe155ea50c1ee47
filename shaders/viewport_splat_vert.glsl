// Viewport (Blender gpu module), quad pass, vertex stage: one instanced quad per splat,
// placed from the preprocess pass's records (viewport_preprocess_frag.glsl), which hold
// draw position gl_InstanceID at texel (id % width, id / width). Needs splat_math.glsl.

void main()
{
    ivec2 at = ivec2(gl_InstanceID % sizes.x, gl_InstanceID / sizes.x);
    vec4 p = texelFetch(rec_pos_tex, at, 0);
    vec4 c = texelFetch(rec_conic_tex, at, 0);
    vec4 col = texelFetch(rec_color_tex, at, 0);
    int mode = int(col.w + 0.5);
    v_conic = c.xyz;
    v_color = col.rgb;
    v_opacity = c.w;
    v_mode = mode;
    v_extent = mode == 2 ? sl_extent_sigma(c.w, flags.z != 0) : 0.0;
    if (!(p.w > 0.0)) {  // culled in the preprocess pass: outside the clip volume, the quad vanishes
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
        v_offset = vec2(0.0);
        return;
    }
    // pixel corner (y down, top-left origin) -> NDC; depth from the centre, for the depth test
    vec2 offset = corner * p.w;
    vec2 pix = p.xy + offset;
    gl_Position = vec4(2.0 * pix.x / frame.x - 1.0, 1.0 - 2.0 * pix.y / frame.y, p.z, 1.0);
    v_offset = offset;
}
