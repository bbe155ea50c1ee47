"""Drop one known line of Blender's C-level noise from stderr, and name final frames in its
stdout, while a CLI render runs.

The engine asks Blender for its GPU context (RenderEngine.bl_use_gpu_context, for the
gpu-module path). On a driver whose OpenGL stops at 4.5 (Mesa's llvmpipe, many Mesa
drivers), Blender's headless EGL set-up first asks for a 4.6 core context, and EGL's
refusal is printed by Blender, not returned: three `EGL Error (0x3009): EGL_BAD_MATCH`
lines before the 4.5 context it then makes works. Blender prints them for any engine that
uses its GPU context (EEVEE too); the driver's version cannot be chosen from Python, so
the command line drops exactly those lines, and only while its render runs. Any other
line, and any other EGL error, passes unchanged and in order; a context that cannot be
made at all still fails the render with Blender's own message.

Blender also prints `Saved: '<path>'` on stdout for each frame it writes, and the path is the
hidden temporary the job writes to (render_job.TemporaryFrames: `.frame_0001.PID.frametmp.png`,
renamed to `frame_0001.png` as soon as Blender has closed it). `final_frame_names` rewrites
such a name, wherever it appears in a stdout line, to the final one, so no temporary name is
ever printed (issue 42).

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

# The pump ignores Ctrl+C: a terminal sends SIGINT to the whole process group, and the
# render's own "interrupted" lines still have to pass through it; it ends when the pipe closes.
_PUMP = (
    "import re, signal, sys\n"
    "signal.signal(signal.SIGINT, signal.SIG_IGN)\n"
    "src, dst = sys.stdin.buffer, sys.stdout.buffer\n"
    "drop, temporary = %r, re.compile(%r)\n"
    "for line in iter(src.readline, b''):\n"
    "    if drop and line.startswith(drop):\n"
    "        continue\n"
    "    dst.write(temporary.sub(rb'\\1\\2\\3', line))\n"
    "    dst.flush()\n"
)
# /.NAME.PID.frametmp.EXT -> /NAME.EXT (render_job.TemporaryFrames's names)
TEMPORARY_NAME = rb"([/\\])\.([^/\\'\"]+?)\.\d+\.frametmp(\.[A-Za-z0-9]+)?"


@contextlib.contextmanager
def without_egl_probe_lines():
    """While the block runs, lines on fd 2 starting with PROBE_LINE are dropped. Where fd 2
    cannot be redirected (no such descriptor, no pipes), nothing is filtered."""
    with _filtered(2, PROBE_LINE, sys.stderr):
        yield


@contextlib.contextmanager
def final_frame_names():
    """While the block runs, a frame's temporary name on fd 1 reads as its final name."""
    with _filtered(1, b"", sys.stdout):
        yield


@contextlib.contextmanager
def _filtered(fd: int, drop: bytes, stream):
    """fd's lines pass through a pump process that drops those starting with `drop` (none
    when empty) and rewrites temporary frame names; unfiltered where fd cannot be redirected."""
    try:
        stream.flush()
        saved = os.dup(fd)
    except (OSError, ValueError, AttributeError):
        yield
        return
    try:
        read_end, write_end = os.pipe()
        pump = subprocess.Popen([sys.executable, "-S", "-c", _PUMP % (drop, TEMPORARY_NAME)],
                                stdin=read_end, stdout=saved, stderr=saved, close_fds=True)
    except OSError:
        os.close(saved)
        yield
        return
    os.close(read_end)
    os.dup2(write_end, fd)
    os.close(write_end)
    try:
        yield
    finally:
        with contextlib.suppress(OSError, ValueError, AttributeError):
            stream.flush()
        os.dup2(saved, fd)  # the pipe's last write end closes: the pump drains it and ends
        os.close(saved)
        with contextlib.suppress(subprocess.TimeoutExpired):
            pump.wait(10)
