"""Instrumented copies of the offscreen renderer's draw shaders, for the benches that take
a frame apart (colour_profile_bench times them, fragment_census counts with them): each
edit replaces one anchor string of a shader's text, and fails loudly when a shader no
longer holds it, so a bench cannot silently measure the unpatched renderer."""
from __future__ import annotations

from addon.core.scene import RenderOptions
from addon.gl import shaders
from bench.final_frame_rows import small as small_camera

V, F = "gl_splat.vert", "gl_splat.frag"
OUTSIDE = "gl_Position = vec4(2.0, 2.0, 2.0, 1.0)"
POSITION = "gl_Position = vec4(ndc.x, ndc.y, 0.5, 1.0);"
FIRST = "    uint k = u_visible - 1u - (u_first + uint(gl_InstanceID));"
CORNERS = "    vec2 pix = r0.xy + axes * corner;"
TRIM = "const float SL_TRIM_AREA = 0.8;"
KEEP = "    alpha = alpha < SL_ALPHA_MIN ? 0.0 : alpha;"
FETCH = "#extension GL_EXT_shader_framebuffer_fetch : require\n"


def patched_source(edits):
    """shaders.source with the edits (file, old, new) applied."""
    plain = shaders.source

    def source(name, *args, **kwargs):
        text = plain(name, *args, **kwargs)
        for file, old, new in edits:
            if file == name:
                if old not in text:
                    raise RuntimeError(f"bench shader patch: {name} no longer holds {old.strip()!r}")
                text = text.replace(old, new)
        return text
    return source


def renderer_for(edits, items, cam, **kwargs):
    """An OffscreenRenderer (colour only) whose programs were built from the edited shaders."""
    from addon.gl import OffscreenRenderer

    plain = shaders.source
    shaders.source = patched_source(edits)
    try:
        r = OffscreenRenderer(depth_pass=False, **kwargs)
        r.render(items, small_camera(cam), RenderOptions())  # builds every program
    finally:
        shaders.source = plain
    return r


def has_fetch(items, cam) -> bool:
    """Whether this GL has GL_EXT_shader_framebuffer_fetch (a fragment reads its pixel)."""
    probe = renderer_for((), items, cam)
    try:
        return "GL_EXT_shader_framebuffer_fetch" in probe._worker.call(lambda: probe._worker.ctx.extensions)
    finally:
        probe.close()
