// Offscreen renderer, stage "draw": one instanced screen-aligned quad per sorted splat.
// Instance k draws order[k] (back to front). Pixels are top-left-origin, y down.
layout(std430, binding = 0) readonly buffer Order { uint order[]; };
layout(std430, binding = 3) readonly buffer Rec0 { vec4 rec0[]; };
layout(std430, binding = 4) readonly buffer Rec1 { vec4 rec1[]; };
layout(std430, binding = 5) readonly buffer Rec2 { vec4 rec2[]; };

uniform vec2 u_frame;    // full frame width, height
uniform vec4 u_tile;     // x0, y0, width, height of the rendered tile, in frame pixels
uniform uint u_visible;  // instances drawn

flat out vec2 v_centre;
flat out vec3 v_conic;
flat out vec4 v_colour;  // rgb, opacity
flat out float v_rank;   // front-to-back rank (depth pass)

void main()
{
    uint idx = order[gl_InstanceID];
    vec4 r0 = rec0[idx], r1 = rec1[idx];
    v_centre = r0.xy;
    v_conic = vec3(r0.zw, r1.x);
    v_colour = vec4(rec2[idx].rgb, r1.w);
    v_rank = float(u_visible - 1u - uint(gl_InstanceID));
    vec2 corner = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1)) * 2.0 - 1.0;
    // clamp to the tile (+1 px) so huge quads cost no more than the frame
    vec2 pix = clamp(r0.xy + corner * r1.y, u_tile.xy - 1.0, u_tile.xy + u_tile.zw + 1.0);
    vec2 ndc = (pix - u_tile.xy) / u_tile.zw * 2.0 - 1.0;
    gl_Position = vec4(ndc.x, -ndc.y, 0.0, 1.0);
}
