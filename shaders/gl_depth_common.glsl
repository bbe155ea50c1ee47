// Offscreen renderer, depth pass: the 8 probe ranks splitting a pixel's interval [lo, hi]
// into 9 parts. Integer arithmetic, so the splat and the update shaders agree exactly.
uint depth_probe(vec2 bounds, uint j)
{
    uint lo = uint(bounds.x), hi = uint(bounds.y);
    return lo + (j * (hi - lo)) / 9u;
}
