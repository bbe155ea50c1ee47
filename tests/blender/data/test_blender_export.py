"""Export through real bpy: a float PLY imported then exported gives back the file's values,
.splat export, the operator, and cross-convention export (reframe)."""
from __future__ import annotations

import numpy as np
import plyfile
import pytest

from addon.core import formats
from addon.core.reframe import reframe
from addon.core.sh import sh_to_rgb
from testing.synth import random_splats

EXACT = ["x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2"]


def _vertex(path):
    return plyfile.PlyData.read(str(path))["vertex"]


def _sigmoid(x):
    return 1.0 / (1.0 + np.exp(-np.asarray(x, np.float64)))


@pytest.mark.parametrize("name", ["guitar.ply", "test64.ply"])
def test_float_ply_round_trip(bpy_empty, testdata, tmp_path, name):
    from addon.blender.data.files import export_object, import_file

    src = testdata / name
    obj = import_file(bpy_empty.context, src)
    out = tmp_path / name
    export_object(obj, out)
    a, b = _vertex(src), _vertex(out)
    assert a.count == b.count
    rest = [p.name for p in a.properties if p.name.startswith("f_rest_")]
    assert rest == [p.name for p in b.properties if p.name.startswith("f_rest_")]
    for p in EXACT + rest:  # stored as they are: bit-exact
        np.testing.assert_array_equal(np.asarray(b[p], np.float32), np.asarray(a[p], np.float32), err_msg=p)
    # opacity: sigmoid in float32 on import, logit in float64 on export. Equal after the
    # sigmoid within one float32 rounding of a value in [0, 1] (2^-24), plus 2^-24 for the
    # exported logit's own rounding to float32.
    np.testing.assert_allclose(_sigmoid(b["opacity"]), _sigmoid(a["opacity"]), rtol=0, atol=2.0**-23)
    # scales: float64 exp rounded to float32 (relative error <= 2^-24), so the log comes
    # back within 2^-24 plus the float32 rounding of the log itself (|log s| < 32 here).
    for p in ("scale_0", "scale_1", "scale_2"):
        la, lb = np.asarray(a[p], np.float64), np.asarray(b[p], np.float64)
        assert np.all(np.abs(la) < 32)
        np.testing.assert_allclose(lb, la, rtol=0, atol=2.0**-24 + 32 * 2.0**-24, err_msg=p)
    # rotations: the importer normalizes (DESIGN.md); compare normalized, float32 rounding
    qa = np.stack([np.asarray(a[f"rot_{i}"], np.float64) for i in range(4)], 1)
    qb = np.stack([np.asarray(b[f"rot_{i}"], np.float64) for i in range(4)], 1)
    qa /= np.linalg.norm(qa, axis=1, keepdims=True)
    np.testing.assert_allclose(qb, qa, rtol=0, atol=4 * 2.0**-24)
    # and the decoded sets agree exactly: what Blender stores is what the file means
    sa, sb = formats.read(src), formats.read(out)
    for field in ("positions", "sh_dc", "sh_rest", "rotations"):
        np.testing.assert_array_equal(getattr(sb, field), getattr(sa, field), err_msg=field)


def test_export_splat_and_operator(bpy_empty, testdata, tmp_path):
    bpy = bpy_empty
    bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "test64.ply"))
    out = tmp_path / "out.splat"
    assert bpy.ops.export_scene.splatline_gaussians(filepath=str(out), file_format="SPLAT") == {"FINISHED"}
    back, src = formats.read(out), formats.read(testdata / "test64.ply")
    assert back.count == src.count
    # .splat stores float32 positions but reorders splats: compare as sets
    assert {tuple(p) for p in back.positions} == {tuple(p) for p in src.positions}

    bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "guitar.splat"))
    for obj in bpy.data.objects:
        obj.select_set(True)
    assert bpy.ops.export_scene.splatline_gaussians(filepath=str(tmp_path / "both.ply")) == {"FINISHED"}
    assert sorted(p.name for p in tmp_path.glob("both_*.ply")) == ["both_guitar.ply", "both_test64.ply"]


def test_export_errors(bpy_empty, testdata, tmp_path):
    from addon.blender.data.files import export_object, import_file
    from addon.core.errors import SplatFormatError

    obj = import_file(bpy_empty.context, testdata / "test64.ply")
    with pytest.raises(SplatFormatError, match="cannot write"):
        export_object(obj, tmp_path / "x.obj")  # .obj: a format with no splat writer
    (tmp_path / "dir.ply").mkdir()
    with pytest.raises(SplatFormatError, match="dir.ply"):
        export_object(obj, tmp_path / "dir.ply")


def test_cross_convention_export_keeps_the_world(bpy_empty, tmp_path):
    """Data stored y-up (RUB) exported to .ply (RDF) lands in the same world place."""
    from addon.blender.data.files import export_object, import_file

    path = tmp_path / "rub.ply"
    formats.write(path, random_splats(50, 3, seed=3))
    rub = import_file(bpy_empty.context, path, axes="RUB")
    export_object(rub, tmp_path / "back.ply")
    rdf = import_file(bpy_empty.context, tmp_path / "back.ply")
    m_rub = np.array(rub.matrix_basis.to_3x3())
    m_rdf = np.array(rdf.matrix_basis.to_3x3())
    a, b = formats.read(path), formats.read(tmp_path / "back.ply")
    # positions are float32 in a few metres: 1e-5 covers two float32 roundings
    np.testing.assert_allclose(b.positions @ m_rdf.T, a.positions @ m_rub.T, atol=1e-5)


def _covariance(s):
    w, x, y, z = s.rotations.astype(np.float64).T
    r = np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                  2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                  2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], 1).reshape(-1, 3, 3)
    rs = r * s.scales.astype(np.float64)[:, None, :]
    return rs @ rs.transpose(0, 2, 1)


@pytest.mark.parametrize("src,dst", [("RUB", "RDF"), ("RDF", "RFU"), ("RFU", "RUB")])
def test_reframe_preserves_geometry_and_colour(src, dst):
    from addon.core.axes import matrix_for

    s = random_splats(40, 3, seed=1)
    s.axes = src
    t = reframe(s, dst)
    r = matrix_for(dst).T @ matrix_for(src)
    # float32 storage of O(1) values: 1e-5 absolute
    np.testing.assert_allclose(t.positions, s.positions @ r.T, atol=1e-5)
    np.testing.assert_allclose(_covariance(t), r @ _covariance(s) @ r.T, atol=1e-5)
    dirs = np.random.default_rng(2).normal(size=(40, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    np.testing.assert_allclose(sh_to_rgb(t.sh_dc, t.sh_rest, dirs @ r.T, 3),
                               sh_to_rgb(s.sh_dc, s.sh_rest, dirs, 3), atol=1e-5)
    assert reframe(s, src) is s


def test_export_evaluated_applies_modifiers(bpy_empty, testdata, tmp_path):
    """evaluated=True writes what the depsgraph makes of the object (here a geometry-nodes
    translation); the default writes the stored data."""
    from addon.blender.data.files import export_object, import_file

    bpy = bpy_empty
    obj = import_file(bpy.context, testdata / "test64.ply")
    tree = bpy.data.node_groups.new("shift", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    group_in, group_out = tree.nodes.new("NodeGroupInput"), tree.nodes.new("NodeGroupOutput")
    move = tree.nodes.new("GeometryNodeTransform")
    move.inputs["Translation"].default_value = (1.0, 2.0, 3.0)
    tree.links.new(group_in.outputs[0], move.inputs["Geometry"])
    tree.links.new(move.outputs["Geometry"], group_out.inputs[0])
    obj.modifiers.new("shift", "NODES").node_group = tree
    export_object(obj, tmp_path / "stored.ply")
    export_object(obj, tmp_path / "evaluated.ply", evaluated=True)
    src = formats.read(testdata / "test64.ply")
    stored, evaluated = formats.read(tmp_path / "stored.ply"), formats.read(tmp_path / "evaluated.ply")
    np.testing.assert_array_equal(stored.positions, src.positions)
    # float32 addition of (1, 2, 3): results stay below 4 in magnitude, so one rounding is
    # at most 2^-23; 2^-20 leaves room for Blender adding in another order
    np.testing.assert_allclose(evaluated.positions, src.positions + np.float32([1, 2, 3]), atol=2.0**-20)
    np.testing.assert_array_equal(evaluated.sh_rest, src.sh_rest)
