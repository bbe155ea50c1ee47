"""An .spz Splatline writes lands where Blender 5.3's own `wm.spz_import` puts it (issue 42):
both read SPZ as RUB, the frame its documentation names. Blender turns the data into its
frame; Splatline keeps the file's values and puts the turn on the object's transform, so
the comparison is in world space: matrix_world @ position, the world rotation of each
splat, and the SH bands turned into the world frame.

Skipped where Blender has no native splats or no wm.spz_import (before 5.3)."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core import formats, quaternion
from addon.core.reframe import rotate_sh

pytestmark = pytest.mark.usefixtures("bpy_empty")


def _world(obj):
    """(N, 3) world positions, (N, 4) world rotations w x y z, (N, K, 3) SH in world axes."""
    import bpy
    from addon.blender.data.pointcloud import splats_from_pointcloud

    bpy.context.view_layer.update()  # matrix_world follows a new rotation only after an update
    s = splats_from_pointcloud(obj.data)
    m = np.array(obj.matrix_world, np.float64)
    linear = m[:3, :3]
    positions = s.positions.astype(np.float64) @ linear.T + m[:3, 3]
    q = quaternion.from_matrix(linear[None])
    rotations = quaternion.multiply(q, s.rotations.astype(np.float64))
    rotations *= np.where(rotations[:, :1] < 0, -1.0, 1.0)  # q and -q: one rotation
    return positions, rotations, rotate_sh(s.sh_rest, linear)


def _blender_import(bpy, path):
    if "spz_import" not in dir(bpy.ops.wm):
        pytest.skip("this Blender has no wm.spz_import")
    assert bpy.ops.wm.spz_import(filepath=str(path)) == {"FINISHED"}
    return bpy.context.view_layer.objects.active


@pytest.mark.parametrize("version", [4, 3])
def test_splatline_spz_matches_blenders_import(native_bpy, testdata, tmp_path, version):
    from addon.blender.data.files import import_file

    bpy = native_bpy
    src = formats.read(testdata / "test64.ply")  # degree 3: the SH bands turn too
    path = tmp_path / "t.spz"
    formats.write(path, src, version=version)
    theirs = _blender_import(bpy, path)
    ours = import_file(bpy.context, path)
    assert ours["splatline_axes"] == "RUB"
    ply = import_file(bpy.context, testdata / "test64.ply")

    pos_b, rot_b, sh_b = _world(theirs)
    pos_s, rot_s, sh_s = _world(ours)
    pos_p, rot_p, _ = _world(ply)
    # the same file: equal up to float32 rounding of Blender's own turn
    np.testing.assert_allclose(pos_s, pos_b, atol=1e-5)
    np.testing.assert_allclose(rot_s, rot_b, atol=1e-5)
    np.testing.assert_allclose(sh_s, sh_b, atol=1e-5)
    # and where the source PLY stands: within SPZ's position step (12 fractional bits)
    assert np.abs(pos_s - pos_p).max() <= 2.0 ** -13 + 1e-6
    assert np.abs(pos_p).max() > 0.1  # a real spread, not all at the origin
    # upright as the PLY: the world's up (+z) agrees in sign with the PLY's for every splat
    assert (np.sign(pos_s[:, 2]) == np.sign(pos_p[:, 2]))[np.abs(pos_p[:, 2]) > 1e-3].all()
    dot = np.abs(np.einsum("ij,ij->i", rot_s, rot_p))
    assert dot.min() > 0.99  # within the 9-bit smallest-three step
