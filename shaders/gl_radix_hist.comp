// Offscreen renderer, GPU radix sort pass 1/3: per-block digit histogram.
// hist is digit-major (digit * num_blocks + block) so one exclusive scan over it gives
// every block's first output slot per digit, in stable order.
layout(local_size_x = 256) in;

layout(std430, binding = 8) readonly buffer Keys { uint keys[]; };
layout(std430, binding = 10) writeonly buffer Hist { uint hist[]; };

uniform uint u_count;
uniform uint u_shift;
uniform uint u_num_blocks;

shared uint counts[256];

void main()
{
    uint t = gl_LocalInvocationID.x, block = gl_WorkGroupID.x;
    counts[t] = 0u;
    barrier();
    uint start = block * BLOCK_SIZE;
    for (uint j = t; j < BLOCK_SIZE; j += 256u) {
        uint i = start + j;
        if (i < u_count) atomicAdd(counts[(keys[i] >> u_shift) & 255u], 1u);
    }
    barrier();
    hist[t * u_num_blocks + block] = counts[t];
}
