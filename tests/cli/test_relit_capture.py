"""A real capture relit by a moving spot light, with a mesh's shadow on it (issue 43), rendered
by the command line: the light animates (frames differ), and a frame is a function of the scene
at that frame (split ranges give the frames of one run, bit for bit)."""
from __future__ import annotations

import numpy as np

from testing.measured_cli import cli


def _frames(folder):
    from testing.engine_scene import read_image

    return {p.name: read_image(p) for p in sorted(folder.glob("frame_*.png"))}


def test_a_spot_sweeping_a_lit_guitar_animates_and_split_ranges_match(bpy_empty, testdata, tmp_path):
    from addon.cli.blender_session import save_blend
    from testing import relit_scene

    bpy = bpy_empty
    relit_scene.build(bpy, testdata, frames=4)
    blend = tmp_path / "relit.blend"
    save_blend(bpy, str(blend))
    whole, split = tmp_path / "whole", tmp_path / "split"
    rc, out, err, _ = cli("render", blend, "--out", whole, "--frames", "1-4", "--format", "PNG")
    assert rc == 0, err
    for part in ("1-2", "3-4"):
        rc, out, err, _ = cli("render", blend, "--out", split, "--frames", part, "--format", "PNG")
        assert rc == 0, err
    one, two = _frames(whole), _frames(split)
    assert sorted(one) == sorted(two) and len(one) == 4
    for name in one:
        np.testing.assert_array_equal(one[name], two[name], err_msg=name)
    first, last = one["frame_0001.png"], one["frame_0004.png"]
    changed = (np.abs(first.astype(float) - last.astype(float)) > 8).any(axis=-1)
    assert changed.mean() > 0.01  # the light moved: the guitar's lit side with it
