"""Effect presets from the command line, as a user types them: `python -m addon import
../shared/testdata/guitar.ply --effect-preset sweep_reveal` (and every other bundled preset,
on guitar and on test64) writes a .blend whose preset reaches its stated end state: read
back through the same evaluation the viewport and F12 use (collect_items), after the
.blend's save and load. test_presets_capture.py checks the same end states in process,
under further object transforms."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from addon.blender.data.presets import find_preset
from addon.core import effect_presets as core
from testing.capture_scenes import item_at, own_item, world_positions
from testing.paths import REPO as ROOT

PRESETS = ("sweep_reveal", "dissolve_out_noise", "fade_in", "glitch_displace", "explode")


def _cli_import(testdata, files, preset, blend):
    proc = subprocess.run([sys.executable, "-m", "addon", "import",
                           *[str(testdata / f) for f in files], "--blend", str(blend),
                           "--effect-preset", preset],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr


def _span(bpy, name):
    preset = core.load(find_preset(name, "effects", ".json"))
    frames = [f for block in [preset.look, *preset.effects] if block
              for points in block.keys.values() for f, _ in points]
    start = bpy.context.scene.frame_start
    return start + min(frames), start + max(frames)








@pytest.mark.parametrize("preset", PRESETS)
@pytest.mark.parametrize("capture", ["guitar.ply", "test64.ply"])
def test_cli_import_preset_reaches_its_end_state(bpy_empty, testdata, tmp_path, capture, preset):
    bpy = bpy_empty
    blend = tmp_path / "out.blend"
    _cli_import(testdata, [capture], preset, blend)
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    from addon.blender.data.evaluated_geometry import is_companion

    (obj,) = [o for o in bpy.data.objects if o.type == "POINTCLOUD" and not is_companion(o)]
    name = obj.name_full
    assert np.abs(np.array(obj.matrix_world)[:3, :3] - np.eye(3)).max() > 0.5  # RDF as a rotation
    first, last = _span(bpy, preset)
    own = own_item(bpy, obj, last).splats
    start, end = item_at(bpy, name, first), item_at(bpy, name, last)
    if preset == "sweep_reveal":  # nothing shown first, then every splat at its own opacity
        assert start.splats.opacities.sum() < 0.01 * own.opacities.sum()
        np.testing.assert_array_equal(end.splats.opacities, own.opacities)
        np.testing.assert_array_equal(end.splats.scales, own.scales)
    elif preset == "dissolve_out_noise":  # whole first, gone at the end
        np.testing.assert_array_equal(start.splats.opacities, own.opacities)
        assert end.splats.opacities.max() == 0.0
    elif preset == "fade_in":
        assert (start.opacity_scale, start.splat_scale) == (0.0, 0.5)
        assert (end.opacity_scale, end.splat_scale) == (1.0, 1.0)
    elif preset == "glitch_displace":  # jumps, then back at rest
        np.testing.assert_array_equal(end.splats.positions, own.positions)
        moved = [not np.array_equal(item_at(bpy, name, f).splats.positions, own.positions)
                 for f in range(int(first), int(last))]
        assert any(moved)
    else:  # explode: at rest at its start, then out from the centre and down the world's Z
        np.testing.assert_array_equal(start.splats.positions, own.positions)
        later = item_at(bpy, name, first + 48)
        moved = world_positions(later) - world_positions(start)
        size = np.ptp(world_positions(start), axis=0).max()
        assert np.median(np.linalg.norm(moved, axis=1)) > 0.5 * size and np.median(moved[:, 2]) < 0


def test_cli_import_morph_guitar_into_test64(bpy_empty, testdata, tmp_path):
    """`import guitar.ply test64.ply --effect-preset morph`: at the end the guitar object
    shows test64 where test64 draws it (its 64 splats, the rest faded out)."""
    bpy = bpy_empty
    blend = tmp_path / "out.blend"
    _cli_import(testdata, ["guitar.ply", "test64.ply"], "morph", blend)
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    source, target = bpy.data.objects["guitar"], bpy.data.objects["test64"]
    _, last = _span(bpy, "morph")
    target.splatline.look.visible = False
    end = item_at(bpy, source.name_full, last)
    target.splatline.look.visible = True
    want = item_at(bpy, target.name_full, last)
    shown = end.splats.opacities > 0
    assert shown.sum() == want.splats.count
    got = world_positions(end)[shown]
    gap = np.linalg.norm(world_positions(want)[:, None] - got[None], axis=2)
    assert gap.min(axis=1).max() < 1e-4 and len(set(gap.argmin(axis=1))) == want.splats.count
