// Offscreen renderer (GL 4.3): splat records of the frame, read in sorted order.
layout(std430, binding = 0) readonly buffer Order { uint order[]; };
layout(std430, binding = 3) readonly buffer Rec0 { vec4 rec0[]; };  // centre u, v; conic A, B
layout(std430, binding = 4) readonly buffer Rec1 { vec4 rec1[]; };  // conic C, radius, depth, opacity
layout(std430, binding = 5) readonly buffer Rec2 { vec4 rec2[]; };  // rgb, unused

// Record `which` (0, 1, 2) of the k-th splat back to front.
vec4 record(int which, uint k)
{
    uint i = order[k];
    return which == 0 ? rec0[i] : which == 1 ? rec1[i] : rec2[i];
}
