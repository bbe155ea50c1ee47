// Viewport (Blender gpu module): the effects the preprocess pass applies itself (Reveal and
// Grade by height, distance or noise, and Displace; core/effects/deferral.py), each the
// numpy kernel's arithmetic in the same order (core/effects/reveal.py, grade.py,
// displace.py), on the base splats' centre, opacity, |scale| and SH DC. Rows:
// addon/blender/viewport/effect_rows.py; pinned to the kernels by
// tests/blender/viewport/test_viewport_effects.py and test_viewport_displace.py.
// Needs object_tex, field_tex, displace_a_tex and displace_b_tex declared
// (GPUShaderCreateInfo) and SL_SH_C0 from splat_math.glsl.

const int EFFECT_TEXELS = 8;

// texel `texel` of a data texture (sizes.x texels a row); the preprocess pass, which
// includes this file first, reads its own textures through it too
vec4 fetch(sampler2D tex, int texel)
{
    return texelFetch(tex, ivec2(texel % sizes.x, texel / sizes.x), 0);
}

// texel `texel` of the object table (objects, light table, effects), in rows of its
// texture's width: one row while it fits (gpu_draw.SplatGPU.set_objects)
vec4 table_texel(int texel)
{
    int width = textureSize(object_tex, 0).x;
    return texelFetch(object_tex, ivec2(texel % width, texel / width), 0);
}

vec4 effect_texel(int row, int k)
{
    return table_texel(row + k);
}

// common.field_values: local = rows of gizmo-from-object applied term by term; noise:
// the core's memoized values at the rest centres, from the object's segment of field_tex
float effect_field(int row, int field, vec3 at, int local_splat)
{
    if (field == 2) {
        int texel = int(effect_texel(row, 1).x) + local_splat;
        return fetch(field_tex, texel).x * 0.5 + 0.5;
    }
    vec4 r2 = effect_texel(row, 3);
    float z = ((at.x * r2.x + at.y * r2.y) + at.z * r2.z) + r2.w;
    if (field == 0) return z;
    vec4 r0 = effect_texel(row, 1), r1 = effect_texel(row, 2);
    float x = ((at.x * r0.x + at.y * r0.y) + at.z * r0.z) + r0.w;
    float y = ((at.x * r1.x + at.y * r1.y) + at.z * r1.z) + r1.w;
    return sqrt((x * x + y * y) + z * z);
}

void reveal_effect(int row, float amount, float f, inout float opacity, inout vec3 scale,
                   inout vec3 dc)
{
    vec4 edge = effect_texel(row, 4), glow = effect_texel(row, 5);
    float s = effect_texel(row, 6).x > 0.5 ? float(f < edge.x)
                                           : clamp((f - edge.x) * edge.y + 0.5, 0.0, 1.0);
    if (glow.w > 0.0) dc += (s * (1.0 - s) * glow.w) * glow.rgb;
    float visible = (s * -2.0 + 3.0) * (s * s);
    float hidden = edge.z > 0.5 ? visible : 1.0 - visible;
    opacity *= hidden * -amount + 1.0;
    if (edge.w > 0.0) scale *= hidden * -edge.w + 1.0;
}

// grade.gradient: piecewise linear between stops sorted by position, a step where two meet
vec3 grade_gradient(int row, int stops, float x)
{
    vec4 first = effect_texel(row, 5);
    vec3 colour = first.yzw;
    for (int k = 1; k < stops; k++) {
        vec4 a = effect_texel(row, 4 + k), b = effect_texel(row, 5 + k);
        float w = b.x > a.x ? clamp((x - a.x) * (1.0 / (b.x - a.x)), 0.0, 1.0) : float(x >= a.x);
        colour += w * (b.yzw - a.yzw);
    }
    return colour;
}

void grade_effect(int row, float gain, float f, inout vec3 dc)
{
    vec4 range = effect_texel(row, 4);
    float x = clamp((f - range.x) * range.y, 0.0, 1.0);
    vec3 g = grade_gradient(row, int(range.w), x);
    int mode = int(range.z);
    vec3 base = dc * SL_SH_C0 + 0.5;
    vec3 delta = mode == 2 ? g : (mode == 0 ? g - base : base * (g - 1.0));
    dc += delta * gain;
}

// The centre a deferred displace among the `count` effects at `first` moves `p` (the
// stack's input centre) to: its two layers' rows blended as displace.apply blends them,
// (a w_a + b w_b) gain + p; `p` itself where there is none.
vec3 displaced(int first, int count, vec3 p, int splat)
{
    for (int e = 0; e < count; e++) {
        int row = first + e * EFFECT_TEXELS;
        if (int(effect_texel(row, 0).x) != 3) continue;
        vec4 w = effect_texel(row, 1);
        vec3 c = fetch(displace_a_tex, splat).xyz * w.x;
        c += fetch(displace_b_tex, splat).xyz * w.y;
        c *= w.z;
        return p + c;
    }
    return p;
}

// Apply the colour effects among the `count` effects whose rows start at texel `first`, in
// stack order. `at` and `rest`: the splat's final and input centres (equal when nothing
// moved it); local_splat: its index within its object.
void apply_effects(int first, int count, vec3 at, vec3 rest, int local_splat, inout float opacity,
                   inout vec3 scale, inout vec3 dc)
{
    for (int e = 0; e < count; e++) {
        int row = first + e * EFFECT_TEXELS;
        vec4 head = effect_texel(row, 0);
        int kind = int(head.x);
        if (kind == 3) continue;  // the displace: displaced()
        float f = effect_field(row, int(head.y), head.z > 0.5 ? rest : at, local_splat);
        if (kind == 1) reveal_effect(row, head.w, f, opacity, scale, dc);
        else grade_effect(row, head.w, f, dc);
    }
}
