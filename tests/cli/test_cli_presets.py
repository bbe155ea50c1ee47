"""Presets from the command line: `render --preset NAME` and `import --effect-preset NAME`."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import bpy  # noqa: F401  (puts bpy_extras on the path)
import pytest
from bpy_extras import anim_utils
from testing.engine_scene import add_camera, add_splats, flat_splats, setup_render

from addon.core import procedural
from addon.core.formats import write
from testing.paths import REPO as ROOT


def _cli(*args, timeout=180, env=None):
    return subprocess.run([sys.executable, "-m", "addon", *map(str, args)], cwd=ROOT,
                          capture_output=True, text=True, timeout=timeout, env=env)


@pytest.fixture
def small_blend(bpy_empty, tmp_path):
    bpy = bpy_empty
    add_splats(bpy, "splats", flat_splats([(0, 0, 0), (0.5, 0.3, 0.2)], [(0.9, 0.2, 0.1), (0.1, 0.4, 0.9)]))
    add_camera(bpy, location=(0.0, -6.0, 0.0))
    scene = setup_render(bpy, 64, 48)
    scene.frame_start = scene.frame_end = 1
    path = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def test_render_preset_picks_the_output(small_blend, tmp_path):
    out = tmp_path / "out"
    proc = _cli("render", small_blend, "--out", out, "--preset", "preview")
    assert proc.returncode == 0, proc.stderr
    import OpenImageIO as oiio

    (frame,) = sorted(out.glob("*.png"))
    spec = oiio.ImageInput.open(str(frame)).spec()
    assert (spec.width, spec.height) == (32, 24)  # the preview preset's 50 %
    proc = _cli("render", small_blend, "--out", tmp_path / "full", "--preset", "preview",
                "--resolution", "40x30")
    assert proc.returncode == 0, proc.stderr
    (frame,) = sorted((tmp_path / "full").glob("*.png"))
    assert oiio.ImageInput.open(str(frame)).spec().width == 40  # explicit flags override the preset


def test_render_unknown_preset_is_one_line(small_blend, tmp_path):
    proc = _cli("render", small_blend, "--out", tmp_path / "o", "--preset", "nope")
    assert proc.returncode == 2  # a usage error
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "nope" in lines[0] and "exr_half_multilayer" in lines[0]


def test_import_with_effect_presets(bpy_empty, tmp_path):
    bpy = bpy_empty
    knot, planet = tmp_path / "knot.ply", tmp_path / "planet.ply"
    write(knot, procedural.torus_knot(2000, degree=0))
    write(planet, procedural.planet(1500, degree=0))
    blend = tmp_path / "out.blend"
    proc = _cli("import", knot, planet, "--blend", blend, "--effect-preset", "fade_in",
                "--effect-preset", "morph")
    assert proc.returncode == 0, proc.stderr
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    first, second = bpy.data.objects["knot"], bpy.data.objects["planet"]
    assert [e.type for e in first.splatline.effects] == ["MORPH"]
    assert first.splatline.effects[0].target == second
    assert len(second.splatline.effects) == 0
    start = bpy.context.scene.frame_start
    for obj in (first, second):
        anim = obj.animation_data
        bag = anim_utils.action_get_channelbag_for_slot(anim.action, anim.action_slot)
        opacity = bag.fcurves.find("splatline.look.opacity")
        assert [p.co[0] for p in opacity.keyframe_points] == [start, start + 24]


def test_import_morph_preset_needs_two_files(tmp_path):
    knot = tmp_path / "knot.ply"
    write(knot, procedural.torus_knot(500, degree=0))
    proc = _cli("import", knot, "--blend", tmp_path / "x.blend", "--effect-preset", "morph")
    assert proc.returncode != 0 and "two files" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "x.blend").exists()


@pytest.mark.parametrize("name, preset, says", [
    ("bad_enum", {"effects": [{"type": "DISPLACE"}, {"type": "REVEAL", "set": {"reveal_shape": "WEDGE"}}]},
     "WEDGE"),
    ("bad_property", {"look": {"keys": {"opacity": [[0, 0.0], [9, 1.0]]}},
                      "effects": [{"type": "TWIST", "set": {"no_such": 1.0}}]}, "no_such"),
])
def test_import_bad_user_effect_preset_is_one_line(tmp_path, name, preset, says):
    """A user's own preset (in Blender's user preset folder) that bpy rejects: one line, no
    traceback, no .blend."""
    scripts = tmp_path / "scripts"
    folder = scripts / "presets" / "splatline" / "effects"
    folder.mkdir(parents=True)
    (folder / f"{name}.json").write_text(json.dumps(preset))
    knot = tmp_path / "knot.ply"
    write(knot, procedural.torus_knot(500, degree=0))
    proc = _cli("import", knot, "--blend", tmp_path / "x.blend", "--effect-preset", name,
                env=dict(os.environ, BLENDER_USER_SCRIPTS=str(scripts)))
    assert proc.returncode != 0 and "Traceback" not in proc.stderr, proc.stderr
    (line,) = proc.stderr.strip().splitlines()
    assert line.startswith("error: ") and name in line and says in line
    assert not (tmp_path / "x.blend").exists()
