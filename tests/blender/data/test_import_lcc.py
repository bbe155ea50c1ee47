"""An XGRIDS LCC scene (written by testing/lcc_files.py) through File > Import and the
command line's import: LOD 0 by default, `--lod N` on the command line, the data as the core
reader decodes it and no turn on the object (LCC is z up: RFU, Blender's own frame)."""
from __future__ import annotations

import numpy as np

from addon.core import formats
from testing.cli_runs import cli
from testing.lcc_files import write_lcc
from testing.synth import random_splats


def _scene(folder):
    return write_lcc(folder, [random_splats(300, 3, seed=1, dc=0.5), random_splats(40, 3, seed=2, dc=0.5)])


def test_operator_imports_lod0_unturned(bpy_empty, tmp_path):
    bpy = bpy_empty
    path = _scene(tmp_path / "scene")
    assert bpy.ops.import_scene.splatline_gaussians(filepath=path) == {"FINISHED"}
    obj = bpy.context.view_layer.objects.active
    expected = formats.read(path)
    assert len(obj.data.points) == expected.count == 300
    assert obj["splatline_axes"] == "RFU" and tuple(obj.rotation_euler) == (0, 0, 0)
    got = np.empty(300 * 3, np.float32)
    obj.data.attributes["position"].data.foreach_get("vector", got)
    np.testing.assert_array_equal(got.reshape(-1, 3), expected.positions)


def test_cli_import_takes_lod(tmp_path):
    path = _scene(tmp_path / "scene")
    blend = tmp_path / "s.blend"
    proc = cli("import", path, "--blend", blend, "--lod", "1")
    assert proc.returncode == 0, proc.stderr
    assert "40 of 40 splats" in proc.stdout
