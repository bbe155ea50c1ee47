"""python -m addon import: writes a .blend that reopens with the objects; bad input exits
non-zero with one line naming the file, and writes no .blend."""
from __future__ import annotations

import subprocess
import sys

import numpy as np

from testing.paths import REPO as ROOT
from testing.native_scene import value_field


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "addon", "import", *map(str, args)],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)


def test_cli_import_writes_blend(bpy_empty, testdata, tmp_path):
    out = tmp_path / "out.blend"
    run = _cli(testdata / "test64.ply", testdata / "guitar.splat", "--blend", out,
               "--max-sh-degree", "1", "--min-opacity", "0.02", "--max-count", "50000")
    assert run.returncode == 0, run.stderr
    assert out.is_file()
    bpy = bpy_empty
    bpy.ops.wm.open_mainfile(filepath=str(out))
    try:
        splats = [o for o in bpy.data.objects if o.type == "POINTCLOUD"]
        assert sorted(o.name for o in splats) == ["guitar", "test64"]
        assert bpy.context.scene.camera is not None  # added, so the .blend renders as it is
        for obj in splats:
            names = sorted(a.name for a in obj.data.attributes if a.name.startswith("radiance:sh_"))
            # .splat holds no higher SH; test64's degree 3 is capped to 1
            want = ["radiance:sh_0", "radiance:sh_1", "radiance:sh_2"] if obj.name == "test64" else []
            assert names == want
            assert obj["splatline_axes"] == "RDF"
            base = np.empty(len(obj.data.points) * 4, np.float32)
            attribute = obj.data.attributes["radiance:base"]
            attribute.data.foreach_get(value_field(attribute), base)
            assert base[3::4].min() >= 0.02
        assert len(bpy.data.objects["guitar"].data.points) == 50000
    finally:
        bpy.ops.wm.read_factory_settings(use_empty=True)


def test_cli_import_errors(testdata, tmp_path):
    out = tmp_path / "out.blend"
    bad = tmp_path / "cut.ply"
    bad.write_bytes((testdata / "test64.ply").read_bytes()[:3000])
    for args, needle in (([testdata / "test64.ply", bad], f"{bad}: truncated"),
                         ([tmp_path], f"{tmp_path}: is a directory")):
        run = _cli(*args, "--blend", out)
        assert run.returncode != 0
        lines = [line for line in run.stderr.splitlines() if line.strip()]
        assert len(lines) == 1 and needle in lines[0], run.stderr
        assert "Traceback" not in run.stderr + run.stdout
        assert not out.exists()
