"""Every CLI render used to print Blender's GPU-context probe lines (`EGL Error (0x3009):
EGL_BAD_MATCH`, Blender asking llvmpipe for GL 4.6 before 4.5). The render drops exactly
those lines (cli/stderr_filter.py); every other line of stderr, C-level included, passes."""
from __future__ import annotations

import subprocess
import sys
import textwrap

from testing.paths import REPO

ROOT = REPO


def test_a_cli_render_prints_no_egl_probe_line(testdata, tmp_path):
    out = tmp_path / "out"
    res = subprocess.run([sys.executable, "-m", "addon", "render", testdata / "test64.ply", "--out", out,
                          "--frames", "1", "--resolution", "32x32"],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert (out / "frame_0001.png").is_file()
    assert "EGL_BAD_MATCH" not in res.stderr + res.stdout, res.stderr


def test_the_filter_drops_only_the_probe_line_and_keeps_the_order():
    code = textwrap.dedent(f"""
        import os, sys
        sys.path.insert(0, {str(ROOT)!r})
        from addon.cli.stderr_filter import without_egl_probe_lines
        os.write(2, b"before\\n")
        with without_egl_probe_lines():
            os.write(2, b"one\\nEGL Error (0x3009): EGL_BAD_MATCH: Arguments are inconsistent\\n")
            print("two", file=sys.stderr, flush=True)
            os.write(2, b"EGL Error (0x3003): EGL_BAD_ALLOC: a real one\\nthree")
        os.write(2, b"\\nafter\\n")
    """)
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=60)
    assert res.returncode == 0, res.stderr
    assert res.stderr.decode().splitlines() == [
        "before", "one", "two", "EGL Error (0x3003): EGL_BAD_ALLOC: a real one", "three", "after"]


def test_a_cli_render_prints_no_temporary_frame_name(testdata, tmp_path):
    """Blender's own `Saved:` line named the hidden temporary the job writes each frame to
    (issue 42: `Saved: '…/.frame_0001.29664.frametmp.png'`); it now names the final file."""
    out = tmp_path / "out"
    res = subprocess.run([sys.executable, "-m", "addon", "render", testdata / "test64.ply", "--out", out,
                          "--frames", "1-2", "--resolution", "32x32"],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    text = res.stdout + res.stderr
    assert "frametmp" not in text, text
    saved = [line for line in res.stdout.splitlines() if "Saved:" in line]
    assert [line.split("Saved: ")[1] for line in saved] == [f"'{out / 'frame_0001.png'}'",
                                                           f"'{out / 'frame_0002.png'}'"], res.stdout


def test_the_stdout_filter_names_final_frames_and_keeps_the_rest():
    code = textwrap.dedent(f"""
        import os, sys
        sys.path.insert(0, {str(ROOT)!r})
        from addon.cli.stderr_filter import final_frame_names
        with final_frame_names():
            os.write(1, b"00:00.5  render | Saved: '/a b/.frame_0001.29664.frametmp.png'\\n")
            print("frame 1  /a b/frame_0001.png", flush=True)
            os.write(1, b"Saved: 'C:\\\\x\\\\.f_07.12.frametmp.exr' and .frametmp alone\\n")
        print("after", flush=True)
    """)
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=60)
    assert res.returncode == 0, res.stderr
    assert res.stdout.decode().splitlines() == [
        "00:00.5  render | Saved: '/a b/frame_0001.png'", "frame 1  /a b/frame_0001.png",
        "Saved: 'C:\\x\\f_07.exr' and .frametmp alone", "after"]
