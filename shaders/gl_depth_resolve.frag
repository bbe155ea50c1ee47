// Offscreen renderer, depth pass: rank -> view depth of that splat; inf where the
// pixel's alpha never reaches 0.5 (rank == visible count).
#include_records

uniform sampler2D u_bounds;
uniform uint u_visible;

out vec4 frag;

void main()
{
    uint rank = uint(texelFetch(u_bounds, ivec2(gl_FragCoord.xy), 0).x);
    float d = uintBitsToFloat(0x7f800000u);
    if (rank < u_visible) d = record(1, u_visible - 1u - rank).z;
    frag = vec4(d, 0.0, 0.0, 1.0);
}
