"""core/linear_map.bake: splats drawn with an identity transform after baking are the splats
drawn through the map before (float64 reference renderer, real captures)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from addon.core import reference
from addon.core.formats import read
from addon.core.linear_map import NotExact, bake
from addon.core.scene import RenderItem
from testing.viewport_scene import camera_for, psnr, rotation


def _frames(splats, world):
    baked = bake(splats, world[:3, :3], world[:3, 3])
    centre = world[:3, :3] @ splats.positions.astype(np.float64).mean(0) + world[:3, 3]
    camera = camera_for(centre, 96, 72)
    before = reference.render([RenderItem(splats, world)], camera).rgba
    after = reference.render([RenderItem(baked, np.eye(4))], camera).rgba
    return before, after


def _world(linear, move=(0.3, -0.2, 0.5)):
    world = np.eye(4)
    world[:3, :3] = linear
    world[:3, 3] = move
    return world


@pytest.mark.parametrize("linear", [
    rotation((0.3, 1.0, 0.5), 50) * 1.7,                    # turn and uniform scale
    rotation((1, 0, 0), -90),                               # a file's axes to Blender's
    rotation((0.2, 0.1, 1.0), 30) @ np.diag([1.0, -1.0, 1.0]) * 0.6,  # a mirror
], ids=["rotate-scale", "axes", "mirror"])
def test_a_similarity_bakes_a_degree_3_capture_exactly(testdata, linear):
    splats = read(testdata / "test64.ply")
    assert splats.sh_degree == 3
    before, after = _frames(splats, _world(linear))
    assert before[..., 3].max() > 0.5
    assert psnr(before, after) >= 100.0  # float32 storage of the baked values only


def test_a_non_uniform_scale_bakes_shapes_exactly_for_degree_0(testdata):
    splats = read(testdata / "test64.ply")
    flat = replace(splats, sh_rest=np.zeros((splats.count, 0, 3), np.float32))
    linear = rotation((0.3, 1.0, 0.5), 50) @ np.diag([1.0, 2.5, 0.4]) @ rotation((1, 0.2, 0), 20)
    before, after = _frames(flat, _world(linear))
    # measured 90 dB: float32 axes of splats stretched 6:1 (a wrong covariance costs < 40)
    assert before[..., 3].max() > 0.5 and psnr(before, after) >= 80.0


def test_a_non_uniform_scale_of_sh_colour_is_refused(testdata):
    splats = read(testdata / "test64.ply")
    with pytest.raises(NotExact, match="non-uniform"):
        bake(splats, np.diag([1.0, 2.0, 1.0]))
    with pytest.raises(ValueError, match="not invertible"):
        bake(splats, np.diag([1.0, 0.0, 1.0]))
