// Offscreen renderer, stage "draw": one instanced screen-aligned quad per sorted splat.
// Instance k draws the k-th splat back to front. Pixels are top-left-origin, y down.
// GL 4.3: records in storage buffers, order[k] from the sort. GL 3.3 fallback
// (SL_TEXTURE_RECORDS): records already sorted on the CPU, in RGBA32F textures.
#include_records

uniform vec2 u_frame;    // full frame width, height
uniform vec4 u_tile;     // x0, y0, width, height of the rendered tile, in frame pixels
uniform uint u_visible;  // instances drawn

flat out vec2 v_centre;
flat out vec3 v_conic;
flat out vec4 v_colour;  // rgb, opacity
flat out float v_rank;   // front-to-back rank (depth pass)

void main()
{
    vec4 r0 = record(0, uint(gl_InstanceID)), r1 = record(1, uint(gl_InstanceID));
    v_centre = r0.xy;
    v_conic = vec3(r0.zw, r1.x);
    v_colour = vec4(record(2, uint(gl_InstanceID)).rgb, r1.w);
    v_rank = float(u_visible - 1u - uint(gl_InstanceID));
    vec2 corner = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1)) * 2.0 - 1.0;
    // clamp to the tile (+1 px) so huge quads cost no more than the frame
    vec2 pix = clamp(r0.xy + corner * r1.y, u_tile.xy - 1.0, u_tile.xy + u_tile.zw + 1.0);
    vec2 ndc = (pix - u_tile.xy) / u_tile.zw * 2.0 - 1.0;
    gl_Position = vec4(ndc.x, -ndc.y, 0.0, 1.0);
}
