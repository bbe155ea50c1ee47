// Offscreen renderer (GL 3.3 fallback): splat records already in back-to-front order,
// in RGBA32F textures RECORD_WIDTH texels wide (same layout as gl_records_ssbo.glsl).
uniform sampler2D u_rec0;
uniform sampler2D u_rec1;
uniform sampler2D u_rec2;

vec4 record(int which, uint k)
{
    ivec2 at = ivec2(int(k % uint(RECORD_WIDTH)), int(k / uint(RECORD_WIDTH)));
    return which == 0 ? texelFetch(u_rec0, at, 0) : which == 1 ? texelFetch(u_rec1, at, 0)
                                                 : texelFetch(u_rec2, at, 0);
}
