// Viewport (Blender gpu module): Look > Lighting in the preprocess pass, the arithmetic of
// core/lighting/shade.py and normals.py (Lambert in Cycles' units, the colour scaled by
// sRGB(albedo x radiance) / colour) in float32, on the splat after its effects. Shadows are
// not cast here: the viewport lights without them (the panel says so).
// Everything is in the view's camera space: the light table (light_rows.py) holds the
// lights, the World's colour and the scene camera there, and a splat's camera-space centre
// is the preprocess pass's t. Needs splat_math.glsl and viewport_effects.glsl (table_texel) first.
//
// Light table, `first` its first texel of object_tex:
//   head   ambient rgb (World colour x strength), light count
//   eye    scene camera xyz, 1 (none: 0, both sides of a splat lit)
//   per light, 4 texels: kind (0 sun, 1 point, 2 spot, 3 area), power or strength,
//   cos(spot size / 2), spot blend; position; the way it shines (unit); colour

const float SL_PI = 3.141592653589793;
const float SL_DARK = 1e-6;             // shade._DARK: a darker DC colour stays as it is
const float SL_LINEAR_KNEE = 0.0031308;

vec4 light_texel(int first, int k)
{
    return table_texel(first + k);
}

// normals.shortest_axes: the rotation's column along the smallest scale (the first of equals)
vec3 sl_shortest_axis(vec4 q, vec3 scale)
{
    mat3 r = sl_quat_to_mat(q);
    int j = 0;
    if (scale.y < scale[j]) j = 1;
    if (scale.z < scale[j]) j = 2;
    return r[j];
}

// normals.world_normals, into camera space: by m's inverse transpose, whose columns are the
// cross products of m's (over det m, whose size the normalisation drops and whose sign not)
vec3 sl_normal_camera(mat3 m, vec3 axis)
{
    vec3 n = cross(m[1], m[2]) * axis.x + cross(m[2], m[0]) * axis.y + cross(m[0], m[1]) * axis.z;
    float len = length(n);
    n = len > 0.0 ? n / len : n;
    return dot(m[0], cross(m[1], m[2])) < 0.0 ? -n : n;
}

float sl_spot_mask(float cos_axis, float cos_half, float blend)
{
    if (!(cos_axis > cos_half)) return 0.0;
    if (blend <= 0.0) return 1.0;
    float t = clamp((cos_axis - cos_half) / ((1.0 - cos_half) * blend), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

// shade.irradiance: E max(0, n.l) of one light (two-sided: |n.l|), W/m^2
float sl_irradiance(vec4 a, vec3 position, vec3 shines, vec3 p, vec3 n, bool two_sided)
{
    int kind = int(a.x);
    if (kind == 0) {
        float c = dot(n, -shines);
        return a.y * (two_sided ? abs(c) : max(c, 0.0));
    }
    vec3 offset = position - p;
    float d2 = max(dot(offset, offset), 1e-12);
    vec3 l = offset * inversesqrt(d2);
    float c = dot(n, l);
    c = two_sided ? abs(c) : max(c, 0.0);
    float cos_axis = -dot(l, shines);
    if (kind == 3) return a.y * max(cos_axis, 0.0) * c / (SL_PI * d2);
    float e = a.y / (4.0 * SL_PI * d2) * c;
    return kind == 2 ? e * sl_spot_mask(cos_axis, a.z, a.w) : e;
}

// shade.radiance_factor without shadows: the lit linear colour of albedo 1 at p, normal n
vec3 sl_radiance(int first, vec3 p, vec3 n)
{
    vec4 head = light_texel(first, 0), eye = light_texel(first, 1);
    bool two_sided = eye.w < 0.5;
    if (!two_sided && dot(n, eye.xyz - p) < 0.0) n = -n;  // normals.facing
    vec3 radiance = head.rgb;
    int count = int(head.w);
    for (int i = 0; i < count; i++) {
        int k = 2 + 4 * i;
        float e = sl_irradiance(light_texel(first, k), light_texel(first, k + 1).xyz,
                                light_texel(first, k + 2).xyz, p, n, two_sided);
        radiance += light_texel(first, k + 3).rgb * (e / SL_PI);
    }
    return radiance;
}

vec3 sl_srgb_encode(vec3 x)  // x >= 0
{
    vec3 high = (1.0 + SL_SRGB_A) * pow(x, vec3(1.0 / 2.4)) - SL_SRGB_A;
    return mix(x * 12.92, high, greaterThan(x, vec3(SL_LINEAR_KNEE)));
}

// shade.colour_factor: k = sRGB(albedo x radiance) / c per channel, blended with 1; a
// negative light darkens to black, no further
vec3 sl_light_factor(vec3 dc, vec3 radiance, float amount)
{
    vec3 c = 0.5 + SL_SH_C0 * dc;
    vec3 lit = sl_srgb_encode(sl_srgb_decode(max(c, vec3(0.0))) * max(radiance, vec3(0.0)));
    vec3 k = mix(vec3(1.0), lit / max(c, vec3(SL_DARK)), greaterThan(c, vec3(SL_DARK)));
    return 1.0 + min(amount, 1.0) * (k - 1.0);
}
