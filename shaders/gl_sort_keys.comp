// Offscreen renderer, stage "sort keys": depth -> fixed-point key over the visible range,
// exactly as core/sort.py depth_keys (float64 arithmetic, truncating cast), so the GPU
// and the CPU sorts order identically. Key 0 = farthest; culled (inf) -> the largest key.
// Splat i goes in at position count - 1 - i, so the stable sort leaves equal keys in
// descending index: the lower index is drawn last, in front (INRIA's and gsplat's tie
// order; core/sort.py draw_order does the same).
layout(local_size_x = 256) in;

layout(std430, binding = 6) readonly buffer Depth { float depth_key_src[]; };
layout(std430, binding = 7) readonly buffer Range { uint range_bits[3]; };
layout(std430, binding = 8) writeonly buffer Keys { uint keys[]; };
layout(std430, binding = 9) writeonly buffer Vals { uint vals[]; };

uniform uint u_count;
uniform uint u_top;  // 0xffff or 0xffffffff

float from_ordered_bits(uint u)
{
    return uintBitsToFloat((u & 0x80000000u) != 0u ? (u & 0x7fffffffu) : ~u);
}

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    float d = depth_key_src[i];
    uint key = u_top;
    if (!isinf(d) && !isnan(d)) {
        double lo = double(from_ordered_bits(range_bits[0]));
        double hi = double(from_ordered_bits(range_bits[1]));
        double span = hi - lo;
        double scale = span > 0.0LF ? double(u_top - 1u) / span : 0.0LF;
        double k = clamp((hi - double(d)) * scale, 0.0LF, double(u_top - 1u));
        key = uint(k);
    }
    uint at = u_count - 1u - i;
    keys[at] = key;
    vals[at] = i;
}
