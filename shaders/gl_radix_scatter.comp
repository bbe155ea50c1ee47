// Offscreen renderer, GPU radix sort pass 3/3: stable scatter of one 8-bit digit.
// Each block walks its elements 256 at a time. An element's rank among equal digits
// before it in the chunk comes from per-digit bit masks over the 256 lanes (atomicOr,
// then bitCount of the lower lanes): stable without subgroup operations.
layout(local_size_x = 256) in;

layout(std430, binding = 8) readonly buffer KeysIn { uint keys_in[]; };
layout(std430, binding = 9) readonly buffer ValsIn { uint vals_in[]; };
layout(std430, binding = 10) readonly buffer Hist { uint hist[]; };
layout(std430, binding = 11) writeonly buffer KeysOut { uint keys_out[]; };
layout(std430, binding = 12) writeonly buffer ValsOut { uint vals_out[]; };

uniform uint u_count;
uniform uint u_shift;
uniform uint u_num_blocks;

shared uint masks[256 * 8];
shared uint offsets[256];

void main()
{
    uint t = gl_LocalInvocationID.x, block = gl_WorkGroupID.x;
    offsets[t] = hist[t * u_num_blocks + block];
    uint word = t >> 5, bit = 1u << (t & 31u);
    for (uint chunk = 0u; chunk < BLOCK_SIZE; chunk += 256u) {
        for (uint w = 0u; w < 8u; w++) masks[t * 8u + w] = 0u;
        barrier();
        uint i = block * BLOCK_SIZE + chunk + t;
        bool live = i < u_count;
        uint key = live ? keys_in[i] : 0u;
        uint digit = (key >> u_shift) & 255u;
        if (live) atomicOr(masks[digit * 8u + word], bit);
        barrier();
        if (live) {
            uint rank = bitCount(masks[digit * 8u + word] & (bit - 1u));
            for (uint w = 0u; w < word; w++) rank += bitCount(masks[digit * 8u + w]);
            uint dst = offsets[digit] + rank;
            keys_out[dst] = key;
            vals_out[dst] = vals_in[i];
        }
        barrier();
        uint total = 0u;
        for (uint w = 0u; w < 8u; w++) total += bitCount(masks[t * 8u + w]);
        offsets[t] += total;
        barrier();
    }
}
