"""moderngl offscreen renderer (standalone EGL/CGL/WGL context on its own thread).

Stages, one module each: upload (per-object buffers cached by RenderItem.key),
preprocess (compute shader, project + depth), sort (GPU radix or CPU numpy), draw
(instanced quads, premultiplied back to front into RGBA32F), depth pass, readback.
The splat math is shaders/splat_math.glsl, shared with the viewport.
"""
from .offscreen_renderer import OffscreenRenderer

__all__ = ["OffscreenRenderer"]
