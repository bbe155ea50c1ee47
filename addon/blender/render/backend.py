"""Which renderer (backend) a final render uses, and why (the Render panel shows it).
Each is a core.renderer.Renderer and declares its own capabilities.

- OFFSCREEN: moderngl on its own standalone context (addon/gl).
- GPU_MODULE: Blender's gpu module drawing the viewport's code offscreen (gpu_render.py).
- REFERENCE: the float64 CPU oracle.
- AUTO: moderngl; if it cannot be imported or cannot make a context (no wheel for the
  platform, no EGL, a driver bug), Blender's gpu module, so a render never fails for lack
  of a wheel or a driver. The reason is logged once per distinct reason.
"""
from __future__ import annotations

import logging
import sys
import threading

log = logging.getLogger("splatline")

_logged: set = set()
_lock = threading.Lock()
_status = {"label": "", "fallback": ""}  # the path of the last render job, for the panel


def moderngl_label(renderer) -> str:
    backend = "EGL" if sys.platform.startswith("linux") else "native"
    name = renderer.gl_info.get("GL_RENDERER", "") if hasattr(renderer, "gl_info") else ""
    return f"Offscreen GL (moderngl, {backend}{', ' + name if name else ''})"


def gpu_label(fallback: str = "") -> str:
    from .gpu_render import backend_name

    label = f"Blender GPU module ({backend_name()})"
    return f"{label} (fallback: {fallback})" if fallback else label


def _moderngl(depth: bool):
    from ...gl import OffscreenRenderer

    return OffscreenRenderer(depth_pass=depth)


def _gpu_module():
    from .gpu_render import GpuModuleRenderer

    return GpuModuleRenderer()


def why_moderngl_failed(exc: BaseException) -> str:
    """One line for the user: the root cause, not the wrapper."""
    root = exc.__cause__ or exc
    if isinstance(root, ImportError):
        return f"moderngl not importable ({root})"
    return f"no OpenGL context ({root})"


def make_renderer(kind: str, depth: bool):
    """(renderer, label) for the RenderSettings.renderer value `kind`."""
    if kind == "REFERENCE":
        from ...core.reference import ReferenceRenderer

        return _set(ReferenceRenderer(), "Reference (float64, CPU)")
    if kind == "GPU_MODULE":
        return _set(_gpu_module(), gpu_label())
    if kind == "OFFSCREEN":
        renderer = _moderngl(depth)
        return _set(renderer, moderngl_label(renderer))
    try:
        renderer = _moderngl(depth)
    except Exception as exc:  # ImportError or RuntimeError from the context factory
        reason = why_moderngl_failed(exc)
        _log_once(reason)
        return _set(_gpu_module(), gpu_label(reason), reason)
    return _set(renderer, moderngl_label(renderer))


def _set(renderer, label, fallback=""):
    with _lock:
        _status["label"], _status["fallback"] = label, fallback
    return renderer, label


def _log_once(reason: str) -> None:
    with _lock:
        if reason in _logged:
            return
        _logged.add(reason)
    # A warning, not an error: the frame still renders, but the user should know why it
    # took the other path (it has no depth pass). Without logging set up, Python's
    # last-resort handler prints warnings to stderr, so a farm log shows it too.
    log.warning("Splatline: rendering through Blender's GPU module: %s", reason)


def last_label() -> str:
    """The path the last render job used ('' before the first)."""
    with _lock:
        return _status["label"]


def moderngl_installed() -> bool:
    import importlib.util

    return importlib.util.find_spec("moderngl") is not None
