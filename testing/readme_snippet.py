"""The README's bpy snippet (its one `python` block) made runnable on a small scene, for the
test that runs it from the checkout (tests/project/test_readme.py) and the one that runs it
after `pip install` (tests/project/test_install.py)."""
from __future__ import annotations

import re
import subprocess

from testing.paths import REPO

# A .blend of guitar.ply from `import`, cut to two 64x36 frames.
SHRINK = """
import bpy
bpy.ops.wm.open_mainfile(filepath={blend!r})
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, 2
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 36, 100
bpy.ops.wm.save_mainfile()
"""


def snippet() -> str:
    text = (REPO / "README.md").read_text()
    (body,) = [b for lang, b in re.findall(r"^```(\w*)\n(.*?)^```", text, flags=re.S | re.M) if lang == "python"]
    return body


def runnable(blend, out, bpy_major: int) -> str:
    """The snippet on `blend`, writing to `out`/frame_####."""
    code = snippet()
    assert '"scene.blend"' in code and '"/tmp/out/frame_"' in code
    code = code.replace('"scene.blend"', repr(str(blend))).replace('"/tmp/out/frame_"', repr(f"{out}/frame_"))
    if bpy_major < 5:  # as its comment says
        code = "\n".join(line for line in code.splitlines() if "(Blender 5.0+)" not in line)
    return code


def shrink(python, blend, env=None) -> None:
    run = subprocess.run([str(python), "-c", SHRINK.format(blend=str(blend))], capture_output=True,
                         text=True, timeout=300, env=env)
    assert run.returncode == 0, run.stderr


def check_frames(out) -> None:
    frames = sorted(p.name for p in out.iterdir())
    assert frames == ["frame_0001.exr", "frame_0002.exr"], frames
    for name in frames:
        assert (out / name).read_bytes()[:4] == b"\x76\x2f\x31\x01"  # OpenEXR's magic number


def bpy_major() -> int:
    import importlib.metadata

    return int(importlib.metadata.version("bpy").split(".")[0])


