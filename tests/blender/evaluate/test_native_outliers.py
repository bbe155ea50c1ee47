"""Blender 5.3: Render > Leave Out Far Outliers hands Blender's engines each capture without
its few far stray splats, decided once per data version (issue 45). On guitar.ply imported
by Blender's own `wm.ply_import`, turned as a user places it. Skipped where Blender has no
native splats (4.5 .. 5.2)."""
from __future__ import annotations

import numpy as np
import pytest


def _guitar_with_strays(bpy, testdata, distance=1_000.0):
    from addon.blender.data.pointcloud import overwrite_pointcloud, splats_from_pointcloud
    from addon.core.edit import merge
    from testing.eevee_outliers import far_splats

    assert bpy.ops.wm.ply_import(filepath=str(testdata / "guitar.ply")) == {"FINISHED"}
    obj = bpy.context.view_layer.objects.active
    obj.rotation_euler = (-np.pi / 2, 0.0, 0.4)
    splats = splats_from_pointcloud(obj.data)
    overwrite_pointcloud(obj.data, merge([splats, far_splats(splats, distance)[0]]))
    bpy.context.view_layer.update()
    return obj, splats


def _handed(bpy, obj):
    from addon.blender.data.pointcloud import read_positions

    return read_positions(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data)


def test_far_strays_are_left_out_once_per_data_version(native_bpy, testdata, capfd):
    from addon.blender.data import evaluated_geometry as geometry
    from addon.blender.evaluate import native_handoff

    bpy = native_bpy
    kept = native_handoff._HANDOFF.kept
    before = kept.found
    obj, splats = _guitar_with_strays(bpy, testdata)
    assert geometry.handoff_modifier(obj) is not None  # a plain import, given a companion for this
    np.testing.assert_array_equal(_handed(bpy, obj), splats.positions)  # all but the 4 strays
    assert "4 far outlier splat(s) of" in capfd.readouterr().err  # said once, not silently
    decided = kept.found
    assert decided > before
    for frame in range(2, 7):  # scrubbing decides nothing again and writes nothing
        bpy.context.scene.frame_set(frame)
        assert native_handoff.sync(bpy.context.evaluated_depsgraph_get()) == 0
    assert kept.found == decided
    assert "far outlier" not in capfd.readouterr().err

    bpy.context.scene.splatline.render.native_outliers = False
    bpy.context.view_layer.update()
    assert len(_handed(bpy, obj)) == splats.count + 4


def test_a_clean_capture_keeps_every_splat_and_gets_no_companion(native_bpy, testdata):
    from addon.blender.data import evaluated_geometry as geometry

    bpy = native_bpy
    assert bpy.context.scene.splatline.render.native_outliers  # on by default
    assert bpy.ops.wm.ply_import(filepath=str(testdata / "guitar.ply")) == {"FINISHED"}
    obj = bpy.context.view_layer.objects.active
    bpy.context.scene.frame_set(2)
    assert geometry.handoff_modifier(obj) is None


def test_effects_keep_the_decision_and_thin_the_evaluated_splats(native_bpy, testdata):
    """An effect changes the splats every frame; the strays are still found on the source's
    splats once, and left out of each frame's evaluated splats."""
    from addon.blender.evaluate import native_handoff
    from testing.effect_ops import add_effect

    bpy = native_bpy
    obj, splats = _guitar_with_strays(bpy, testdata)
    add_effect(bpy, obj, "EXPLODE", start_frame=1.0, strength=0.3)
    bpy.context.scene.frame_set(1)
    decided = native_handoff._HANDOFF.kept.found
    for frame in (3, 5):
        bpy.context.scene.frame_set(frame)
        assert len(_handed(bpy, obj)) == splats.count
    assert native_handoff._HANDOFF.kept.found == decided


def test_only_eevees_own_crash_runs_a_child_again():
    import signal
    from subprocess import CompletedProcess

    from testing.eevee_outliers import upstream_eevee_crash

    def run(code, err=""):
        return CompletedProcess([], code, "", err)

    assert upstream_eevee_crash(run(-signal.SIGABRT, "corrupted size vs. prev_size\n"))
    assert upstream_eevee_crash(run(-signal.SIGSEGV))
    assert not upstream_eevee_crash(run(-signal.SIGABRT, "Assertion failed\n"))
    assert not upstream_eevee_crash(run(1, "Traceback (most recent call last):\n"))
    assert not upstream_eevee_crash(run(0))


@pytest.mark.parametrize("distance", [100_000.0])
def test_eevee_keeps_its_precision_with_the_guard_on(native_bpy, tmp_path, distance):
    """EEVEE, each render in a child process (testing/eevee_outliers.py): with the guard on
    the strays change nothing; off, they cost the covered pixels most of their PSNR."""
    from testing.eevee_outliers import covered_psnr, render_in_child

    base, _, err = render_in_child(0, tmp_path / "base", guard=False)
    assert base is not None, err[-2000:]
    on, _, err = render_in_child(distance, tmp_path / "on", guard=True)
    assert on is not None, err[-2000:]
    off, _, err = render_in_child(distance, tmp_path / "off", guard=False)
    assert off is not None, err[-2000:]
    psnr_on, covered = covered_psnr(on, base)
    psnr_off, _ = covered_psnr(off, base)
    print(f"{covered} covered pixels: guard on {psnr_on:.1f} dB, off {psnr_off:.1f} dB")
    assert covered > 500
    assert psnr_on >= 60.0
    assert psnr_off < 30.0
