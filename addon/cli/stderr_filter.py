"""Drop one known line of Blender's C-level noise from stderr while a CLI render runs.

The engine asks Blender for its GPU context (RenderEngine.bl_use_gpu_context, for the
gpu-module path). On a driver whose OpenGL stops at 4.5 (Mesa's llvmpipe, many Mesa
drivers), Blender's headless EGL set-up first asks for a 4.6 core context, and EGL's
refusal is printed by Blender, not returned: three `EGL Error (0x3009): EGL_BAD_MATCH`
lines before the 4.5 context it then makes works. Blender prints them for any engine that
uses its GPU context (EEVEE too); the driver's version cannot be chosen from Python, so
the command line drops exactly those lines, and only while its render runs. Any other
line, and any other EGL error, passes unchanged and in order; a context that cannot be
made at all still fails the render with Blender's own message.

C code writes fd 2 directly, so the filter is at the descriptor: fd 2 becomes a pipe read
by a small child process (not a thread: Blender may hold the GIL while it writes) that
copies every other line to the real stderr. The child ends when the pipe closes, so even
a killed render leaves nothing behind.
"""
from __future__ import annotations

import contextlib
import os
import subprocess
import sys

PROBE_LINE = rb"EGL Error (0x3009): EGL_BAD_MATCH:"

_PUMP = (
    "import sys\n"
    "src, dst = sys.stdin.buffer, sys.stdout.buffer\n"
    "for line in iter(src.readline, b''):\n"
    "    if not line.startswith(%r):\n"
    "        dst.write(line)\n"
    "        dst.flush()\n" % PROBE_LINE
)


@contextlib.contextmanager
def without_egl_probe_lines():
    """While the block runs, lines on fd 2 starting with PROBE_LINE are dropped. Where fd 2
    cannot be redirected (no such descriptor, no pipes), nothing is filtered."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError, AttributeError):
        yield
        return
    try:
        read_end, write_end = os.pipe()
        pump = subprocess.Popen([sys.executable, "-S", "-c", _PUMP], stdin=read_end,
                                stdout=saved, stderr=saved, close_fds=True)
    except OSError:
        os.close(saved)
        yield
        return
    os.close(read_end)
    os.dup2(write_end, 2)
    os.close(write_end)
    try:
        yield
    finally:
        with contextlib.suppress(OSError, ValueError, AttributeError):
            sys.stderr.flush()
        os.dup2(saved, 2)  # the pipe's last write end closes: the pump drains it and ends
        os.close(saved)
        with contextlib.suppress(subprocess.TimeoutExpired):
            pump.wait(10)
