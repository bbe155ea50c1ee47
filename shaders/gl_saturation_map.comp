// Offscreen renderer, early termination: the saturation map, a pyramid of bitmaps. Level k
// has one bit per (4 << k)-pixel square cell of the tile, set where every pixel of the cell
// has transmittance below SL_T_STOP (pixels outside the tile count as saturated, since
// nothing is drawn there). A row of cells is packed 32 to a uint, lowest bit first, so the
// draw stage reads a row of a splat's footprint in one or two loads.
// Three passes, each its own program (SL_PASS, from composite.py): llvmpipe runs every
// branch of a shader under a lane mask, so one program switching on a uniform paid for
// all three in each:
// - cells (0): one invocation per level-0 cell, reading the colour target's alpha (1 - T)
//   into a uint per cell (a lane per 32-cell word took 5.5 ms at 1080p against 2.1 for a
//   lane per cell, both as branches of one program);
// - pack (1): one invocation per level-0 word, from those uints;
// - reduce (2): one invocation per word of level k > 0, ANDing 2x2 blocks of level k - 1.
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 8) buffer Saturation { uint flags[]; };
layout(std430, binding = 9) buffer Cells { uint cells[]; };

uniform sampler2D u_colour;  // the tile's colour target (rows top-down, as the map's)
uniform uvec2 u_size;        // this level's words (cells pass: cells) per row, rows
uniform uint u_cells;        // level 0's cells per row
uniform uvec2 u_below_size;  // level k - 1's words per row, rows (k > 0)
uniform uint u_offset;       // this level's first word
uniform uint u_below;        // level k - 1's first word
uniform ivec2 u_tile_size;

const float SL_T_STOP = 1.0e-4;  // twin of core/render_constants.py T_STOP

#ifdef SL_HOLDOUT
// Holdout (issue 25; the cells pass only): a cell is closed too where its surface lies at
// or in front of every splat still to be drawn: the farthest surface under the cell
// (gl_holdout_cells.comp) against the least centre depth of the remaining batches
// (gl_holdout_minima.comp); their fragments there would all be dropped. u_saturate false
// (early termination off): closed only so.
layout(std430, binding = 13) readonly buffer Minima { uint minima[]; };
layout(std430, binding = 14) readonly buffer CellMax { float cell_max[]; };
uniform uint u_batch;    // the next batch
uniform uint u_batches;  // batches in the frame
uniform bool u_saturate;

// ordered bits (gl_holdout_minima.comp) -> float; none left (all ones): NaN, closes nothing
float from_ordered_bits(uint u)
{
    return uintBitsToFloat((u & 0x80000000u) != 0u ? (u & 0x7FFFFFFFu) : ~u);
}

bool cell_held(uvec2 cell)
{
    uint least = 0xFFFFFFFFu;
    for (uint b = u_batch; b < u_batches; b++) least = min(least, minima[b]);
    return cell_max[cell.y * u_size.x + cell.x] <= from_ordered_bits(least);
}
#endif

// all 16 pixels read, no early exit: with one (divergent across lanes on llvmpipe) the
// pass took 5.0-5.2 ms at 1080p against 2.5
bool cell_saturated(ivec2 cell)
{
    bool all_done = true;
    for (int j = 0; j < 4; j++) {
        for (int i = 0; i < 4; i++) {
            ivec2 p = cell * 4 + ivec2(i, j);
            if (p.x < u_tile_size.x && p.y < u_tile_size.y
                    && texelFetch(u_colour, p, 0).a <= 1.0 - SL_T_STOP) all_done = false;
        }
    }
    return all_done;
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
#if SL_PASS == 0
#ifdef SL_HOLDOUT
    cells[w.y * u_size.x + w.x] = (u_saturate && cell_saturated(ivec2(w))) || cell_held(w) ? 1u : 0u;
#else
    cells[w.y * u_size.x + w.x] = cell_saturated(ivec2(w)) ? 1u : 0u;
#endif
#elif SL_PASS == 1
    uint word = 0u;
    for (uint b = 0u; b < 32u; b++) {
        uint x = w.x * 32u + b;
        // cells past the tile's right edge count as saturated
        if (x >= u_cells || cells[w.y * u_cells + x] != 0u) word |= 1u << b;
    }
    flags[w.y * u_size.x + w.x] = word;
#else
    // the 64 cells below these 32: two words of each of two rows; a cell is saturated
    // where both rows' bits are, for both cells of its pair
    uint lo = below(2u * w.x, 2u * w.y) & below(2u * w.x, 2u * w.y + 1u);
    uint hi = below(2u * w.x + 1u, 2u * w.y) & below(2u * w.x + 1u, 2u * w.y + 1u);
    flags[u_offset + w.y * u_size.x + w.x] = even_bits(lo & (lo >> 1)) | (even_bits(hi & (hi >> 1)) << 16);
#endif
}
