"""Files that change while a command reads them (issue 41), through `import --blend` and a
sequence render: one line and nothing written, or, in a sequence, the documented held frame.
Each command runs in a child with the change landing at a chosen block of the read
(readfile.after_block via testing/read_faults.py), so a SIGBUS would be its exit code."""
from __future__ import annotations

import shutil
import subprocess
import sys

import pytest

from testing.measured_cli import one_line
from testing.paths import REPO
from testing.read_faults import age, cli_with_fault

READERS = ("test64.ply", "test64.compressed.ply", "test64.splat", "test64.spz", "test64.sog", "test64.glb")


@pytest.mark.parametrize("name", READERS)
def test_import_of_a_file_that_shrinks_writes_no_blend(testdata, tmp_path, name):
    path = tmp_path / name
    shutil.copyfile(testdata / name, path)
    blend = tmp_path / "out" / "scene.blend"
    blend.parent.mkdir()
    rc, out, err = cli_with_fault(path, "truncate", 2, "import", path, "--blend", blend)
    assert rc == 1, (rc, err)
    one_line(err, str(path), "shrank while it was read")
    assert sorted(p.name for p in blend.parent.iterdir()) == []


_MAKE_SEQUENCE = r"""
import sys, bpy
from pathlib import Path
from addon import register
from addon.blender.data.sequences import import_sequence
from testing.sequence_files import write_frames
register()
bpy.ops.wm.read_factory_settings(use_empty=True)
paths = write_frames(Path(sys.argv[1]) / "frames", count=4, n=3000, degree=1)
obj = import_sequence(bpy.context, paths[0].parent, set_scene_range=True)
obj.splatline.sequence.read_ahead = 0  # the frame's own read meets the change (read-ahead: tests/blender)
bpy.ops.object.camera_add(location=(0, -6, 0), rotation=(1.5708, 0, 0))
bpy.context.scene.camera = bpy.context.object
bpy.ops.wm.save_as_mainfile(filepath=str(Path(sys.argv[1]) / "scene.blend"))
"""


@pytest.fixture(scope="module")
def sequence_blend(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sequence")
    subprocess.run([sys.executable, "-c", _MAKE_SEQUENCE, str(folder)], cwd=REPO, check=True,
                   capture_output=True, timeout=300)
    return folder


@pytest.mark.parametrize("action, reason", [("truncate", "shrank while it was read"),
                                            ("grow", "changed size while it was read"),
                                            ("replace", "replaced while it was read"),
                                            ("rewrite", "rewritten while it was read")])
def test_sequence_render_holds_the_previous_frame_of_a_changing_file(sequence_blend, tmp_path, action, reason):
    folder = tmp_path / "seq"
    shutil.copytree(sequence_blend, folder)
    frame = folder / "frames" / "frame_0002.ply"
    age(frame)
    out = tmp_path / "out"
    rc, stdout, err = cli_with_fault(frame, action, 0, "render", folder / "scene.blend", "--out", out,
                                     "--frames", "1-3", "--resolution", "64x48",
                                     block=64 << 10, donor=folder / "frames" / "frame_0004.ply")
    assert rc == 0, (rc, err)
    assert sorted(p.name for p in out.iterdir()) == ["frame_0001.png", "frame_0002.png", "frame_0003.png"]
    held = [ln for ln in err.splitlines() if "frame_0002.ply" in ln]
    assert len(held) == 1 and reason in held[0] and "holding frame 0" in held[0], err
