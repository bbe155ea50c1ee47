"""What changes when the GL rasterises on the CPU (Mesa's llvmpipe on a render farm, WARP,
SwiftShader): which sort runs (gl/sort.sorts_on_gpu) and how the splats' draws are
submitted (gl/composite.Compositor.flush)."""
from __future__ import annotations

import ctypes

# GL_RENDERER names of rasterisers that run on the CPU: Mesa's llvmpipe, softpipe and
# swrast, Google's SwiftShader, Windows' WARP ("Microsoft Basic Render Driver") and
# Apple's "Apple Software Renderer"
SOFTWARE_GL = ("llvmpipe", "softpipe", "swrast", "swiftshader", "basic render", "software renderer")


def is_software(gl_renderer: str) -> bool:
    name = gl_renderer.lower()
    return any(soft in name for soft in SOFTWARE_GL)


def gl_flush(ctx):
    """A callable glFlush for the moderngl context `ctx` (call it on the context's thread),
    or None where it cannot be had. moderngl has no flush; the address comes from the
    loader moderngl itself loads its GL functions with (glcontext's, on every backend),
    which moderngl 5.12 keeps as ctx.mglo._context."""
    loader = getattr(getattr(ctx.mglo, "_context", None), "load", None)
    if loader is None:
        return None
    try:
        address = loader("glFlush")
    except Exception:  # noqa: BLE001 - a backend without it: draw without flushing
        return None
    return ctypes.CFUNCTYPE(None)(address) if address else None
