// Viewport (Blender gpu module), fragment stage: Gaussian falloff, premultiplied output.
// Needs splat_math.glsl before this file. Modes: 0 Gaussian, 1 point dot, 2 opaque ellipse.

void main()
{
    float alpha;
    if (v_mode == 1) {
        alpha = 1.0;
    } else if (v_mode == 2) {  // falloff off: solid out to the quad's extent, to see it
        vec2 d = v_offset;
        float m2 = v_conic.x * d.x * d.x + 2.0 * v_conic.y * d.x * d.y + v_conic.z * d.y * d.y;
        if (m2 > v_extent * v_extent) discard;
        alpha = 1.0;
    } else {
        alpha = sl_alpha(v_offset, v_conic, v_opacity);
        if (alpha < SL_ALPHA_MIN) discard;
    }
    frag_color = vec4(v_color * alpha, alpha);
}
