// Offscreen renderer, holdout on the compute path: the farthest surface depth under each
// 4x4-pixel cell of the tile (the saturation map's level 0), from the tile's surface map
// (gl_holdout.frag; +inf where no surface). Once per tile: between batches the cells
// pass closes a cell where this lies at or in front of every splat still to come.
// Pixels outside the tile add nothing (a cell wholly outside: -inf, closed, as the
// cells pass counts them saturated).
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 14) writeonly buffer CellMax { float cell_max[]; };

uniform sampler2D u_holdout;
uniform uvec2 u_size;       // cells per row, rows
uniform ivec2 u_tile_size;

void main()
{
    uvec2 w = gl_GlobalInvocationID.xy;
    if (w.x >= u_size.x || w.y >= u_size.y) return;
    float m = -uintBitsToFloat(0x7f800000u);
    for (int j = 0; j < 4; j++) {
        for (int i = 0; i < 4; i++) {
            ivec2 p = ivec2(w) * 4 + ivec2(i, j);
            if (p.x < u_tile_size.x && p.y < u_tile_size.y) m = max(m, texelFetch(u_holdout, p, 0).r);
        }
    }
    cell_max[w.y * u_size.x + w.x] = m;
}
