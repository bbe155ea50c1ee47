// Offscreen renderer, early termination: the saturation map, a pyramid of bitmaps. Level k
// has one bit per (4 << k)-pixel square cell of the tile, set where every pixel of the cell
// has transmittance below SL_T_STOP (pixels outside the tile count as saturated, since
// nothing is drawn there). A row of cells is packed 32 to a uint, lowest bit first, so the
// draw stage reads a row of a splat's footprint in one or two loads.
// One invocation per uint: level 0 reads the colour target's alpha (1 - T); level k > 0
// ANDs each 2x2 block of level k - 1's cells.
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 8) buffer Saturation { uint flags[]; };

uniform sampler2D u_colour;  // the tile's colour target (rows top-down, as the map's)
uniform int u_level;
uniform uvec2 u_size;        // this level's words per row, rows
uniform uvec2 u_below_size;  // level k - 1's words per row, rows (k > 0)
uniform uint u_offset;       // this level's first word
uniform uint u_below;        // level k - 1's first word
uniform ivec2 u_tile_size;

const float SL_T_STOP = 1.0e-4;  // twin of core/reference.py T_STOP

bool cell_saturated(ivec2 cell)
{
    for (int j = 0; j < 4; j++) {
        for (int i = 0; i < 4; i++) {
            ivec2 p = cell * 4 + ivec2(i, j);
            if (p.x < u_tile_size.x && p.y < u_tile_size.y
                    && texelFetch(u_colour, p, 0).a <= 1.0 - SL_T_STOP) return false;
        }
    }
    return true;
}

// word (x, y) of level k - 1; all ones (saturated) past its edges
uint below(uint x, uint y)
{
    if (x >= u_below_size.x || y >= u_below_size.y) return 0xFFFFFFFFu;
    return flags[u_below + y * u_below_size.x + x];
}

// bits 0, 2, 4, .. 30 of v packed into bits 0 .. 15
uint even_bits(uint v)
{
    v &= 0x55555555u;
    v = (v | (v >> 1)) & 0x33333333u;
    v = (v | (v >> 2)) & 0x0F0F0F0Fu;
    v = (v | (v >> 4)) & 0x00FF00FFu;
    return (v | (v >> 8)) & 0x0000FFFFu;
}

void main()
{
    uvec2 w = gl_GlobalInvocationID.xy;
    if (w.x >= u_size.x || w.y >= u_size.y) return;
    uint word = 0u;
    if (u_level == 0) {
        for (uint b = 0u; b < 32u; b++) {
            if (cell_saturated(ivec2(w.x * 32u + b, w.y))) word |= 1u << b;
        }
    } else {
        // the 64 cells below these 32: two words of each of two rows; a cell is saturated
        // where both rows' bits are, for both cells of its pair
        uint lo = below(2u * w.x, 2u * w.y) & below(2u * w.x, 2u * w.y + 1u);
        uint hi = below(2u * w.x + 1u, 2u * w.y) & below(2u * w.x + 1u, 2u * w.y + 1u);
        word = even_bits(lo & (lo >> 1)) | (even_bits(hi & (hi >> 1)) << 16);
    }
    flags[u_offset + w.y * u_size.x + w.x] = word;
}
