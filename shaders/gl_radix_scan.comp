// Offscreen renderer, GPU radix sort pass 2/3: exclusive prefix sum over the whole
// histogram in one work group (it holds 256 * blocks entries: small).
layout(local_size_x = 1024) in;

layout(std430, binding = 10) buffer Hist { uint hist[]; };

uniform uint u_length;

shared uint partial[1024];

void main()
{
    uint t = gl_LocalInvocationID.x;
    uint per = (u_length + 1023u) / 1024u;
    uint lo = min(t * per, u_length), hi = min(lo + per, u_length);
    uint sum = 0u;
    for (uint i = lo; i < hi; i++) sum += hist[i];
    partial[t] = sum;
    barrier();
    // Hillis-Steele inclusive scan of the 1024 partial sums
    for (uint off = 1u; off < 1024u; off <<= 1) {
        uint add = t >= off ? partial[t - off] : 0u;
        barrier();
        partial[t] += add;
        barrier();
    }
    uint run = partial[t] - sum;
    for (uint i = lo; i < hi; i++) {
        uint v = hist[i];
        hist[i] = run;
        run += v;
    }
}
