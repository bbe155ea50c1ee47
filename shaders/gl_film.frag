// Offscreen renderer, film pass (needs splat_math.glsl before it): the composited tile in the terms of Blender's render
// result (core/scene.py Film; blender/render/film.result_rect is the reference): the
// display background behind the splats (gl/frame.behind), the straight colour decoded
// from sRGB to scene-linear and premultiplied again, the world under it, rows bottom-up.
// The same float32 steps as the numpy code, in the same order, so the two differ only by
// the power's rounding.
uniform sampler2D u_colour;  // the tile's colour target, top row first
uniform vec4 u_background;   // premultiplied display sRGB behind the splats
uniform vec3 u_under;        // scene-linear world colour, where u_over
uniform bool u_over;
uniform int u_rows;          // the tile's height

out vec4 film;

void main()
{
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 c = texelFetch(u_colour, ivec2(p.x, u_rows - 1 - p.y), 0);
    c += (1.0 - c.a) * u_background;
    vec3 linear = c.a > 0.0 ? sl_srgb_decode(c.rgb / c.a) * c.a : vec3(0.0);
    film = u_over ? vec4(linear + (1.0 - c.a) * u_under, 1.0) : vec4(linear, c.a);
}
