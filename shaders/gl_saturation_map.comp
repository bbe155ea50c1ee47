// Offscreen renderer, early termination: the saturation map, a pyramid of flags. Level k
// has one uint per (4 << k)-pixel square cell of the tile: 1 where every pixel of the cell
// has transmittance below SL_T_STOP (pixels outside the tile count as saturated, since
// nothing is drawn there). The draw stage culls a splat whose quad lies in flagged cells.
// Level 0 reads the colour target's alpha (1 - T); level k > 0 ANDs four cells of k - 1.
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 8) buffer Saturation { uint flags[]; };

uniform sampler2D u_colour;  // the tile's colour target (rows top-down, as the flags')
uniform int u_level;
uniform uvec2 u_size;        // this level's cells
uniform uvec2 u_below_size;  // level k - 1's cells (k > 0)
uniform uint u_offset;       // this level's first flag
uniform uint u_below;        // level k - 1's first flag
uniform ivec2 u_tile_size;

const float SL_T_STOP = 1.0e-4;  // twin of core/reference.py T_STOP

void main()
{
    uvec2 c = gl_GlobalInvocationID.xy;
    if (c.x >= u_size.x || c.y >= u_size.y) return;
    uint all_done = 1u;
    if (u_level == 0) {
        for (int j = 0; j < 4; j++) {
            for (int i = 0; i < 4; i++) {
                ivec2 p = ivec2(c) * 4 + ivec2(i, j);
                if (p.x < u_tile_size.x && p.y < u_tile_size.y
                        && texelFetch(u_colour, p, 0).a <= 1.0 - SL_T_STOP) all_done = 0u;
            }
        }
    } else {
        for (uint j = 0u; j < 2u; j++) {
            for (uint i = 0u; i < 2u; i++) {
                uvec2 b = c * 2u + uvec2(i, j);
                if (b.x < u_below_size.x && b.y < u_below_size.y)
                    all_done &= flags[u_below + b.y * u_below_size.x + b.x];
            }
        }
    }
    flags[u_offset + c.y * u_size.x + c.x] = all_done;
}
