// Offscreen renderer, holdout with batches (GL 4.3): the smallest centre depth (rec1.z,
// the value the draw stage tests against the holdout) of one front-to-back batch, into
// minima[u_slot] as order-preserving bits, and the largest of the frame (the depth
// encoding's range, gl/composite.py). A batch's splats all lie at or behind its minimum,
// so between batches every cell whose farthest surface lies at or in front of the least
// minimum of the batches still to come is closed for them (gl_saturation_map.comp),
// exactly: their fragments there would all be dropped. Each invocation takes SPAN ranks,
// one atomic each.
#include_records

layout(local_size_x = 64) in;
layout(std430, binding = 13) buffer Minima { uint minima[]; };

uniform uint u_visible;  // splats in the frame's order (back to front)
uniform uint u_first;    // the batch's first front-to-back rank
uniform uint u_count;    // and its splats
uniform uint u_slot;
uniform uint u_max_slot;  // where the largest centre depth of all batches goes (atomicMax)

const uint SPAN = 64u;

uint ordered_bits(float f)
{
    uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : (u | 0x80000000u);
}

void main()
{
    uint start = gl_GlobalInvocationID.x * SPAN;
    if (start >= u_count) return;
    uint stop = min(start + SPAN, u_count);
    float z = uintBitsToFloat(0x7f800000u), far = -z;  // +inf, -inf
    for (uint r = start; r < stop; r++) {
        float d = record(1, u_visible - 1u - (u_first + r)).z;
        z = min(z, d);
        far = max(far, d);
    }
    atomicMin(minima[u_slot], ordered_bits(z));
    atomicMax(minima[u_max_slot], ordered_bits(far));
}
