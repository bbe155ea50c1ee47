"""Bad input through the Blender importer: one clear "<file>: <reason>" error, and nothing
half-made left in bpy.data (no object, PointCloud or mesh)."""
from __future__ import annotations

import gzip
import struct

import pytest

from addon.core.errors import SplatFormatError
from testing.native_scene import value_field

_HEADER = ("ply\nformat binary_little_endian 1.0\nelement vertex {n}\n"
           + "".join(f"property float {p}\n" for p in
                     "x y z f_dc_0 f_dc_1 f_dc_2 opacity scale_0 scale_1 scale_2 rot_0 rot_1 rot_2 rot_3".split())
           + "end_header\n")


def _truncated(tmp_path, testdata):
    data = (testdata / "test64.ply").read_bytes()
    path = tmp_path / "truncated.ply"
    path.write_bytes(data[: len(data) // 2])
    return path, "truncated"


def _huge_header(tmp_path, testdata):
    path = tmp_path / "huge.ply"
    head = _HEADER.format(n=10**9).encode()
    path.write_bytes(head + b"\0" * (1024 - len(head)))
    return path, "truncated"


def _directory(tmp_path, testdata):
    path = tmp_path / "folder.ply"
    path.mkdir()
    return path, "directory"


def _empty(tmp_path, testdata):
    path = tmp_path / "empty.ply"
    path.write_bytes(b"")
    return path, "empty"


def _zero_splats(tmp_path, testdata):
    path = tmp_path / "zero.ply"
    path.write_bytes(_HEADER.format(n=0).encode())
    return path, "no splats"


def _spz_magic(tmp_path, testdata):
    path = tmp_path / "magic.spz"
    path.write_bytes(b"JUNK" + bytes(200))
    return path, "magic"


def _spz_inner_magic(tmp_path, testdata):
    # a valid gzip stream whose SPZ header has the wrong magic
    path = tmp_path / "inner.spz"
    path.write_bytes(gzip.compress(struct.pack("<IIIBBBB", 0x12345678, 2, 10, 0, 12, 0, 0) + bytes(400)))
    return path, "magic"


CASES = [_truncated, _huge_header, _directory, _empty, _zero_splats, _spz_magic, _spz_inner_magic]


def _counts(bpy):
    return len(bpy.data.objects), len(bpy.data.pointclouds), len(bpy.data.meshes)


@pytest.mark.parametrize("make", CASES, ids=[c.__name__.strip("_") for c in CASES])
def test_bad_file_leaves_nothing(bpy_empty, testdata, tmp_path, make):
    from addon.blender.data.files import import_file

    bpy = bpy_empty
    bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "test64.ply"))  # something already there
    path, reason = make(tmp_path, testdata)
    before = _counts(bpy)
    with pytest.raises(SplatFormatError) as info:
        import_file(bpy.context, path)
    assert info.value.path == str(path) and reason in info.value.reason.lower()
    assert _counts(bpy) == before
    with pytest.raises(RuntimeError) as info:  # an operator's ERROR report raises in bpy.ops
        bpy.ops.import_scene.splatline_gaussians(filepath=str(path))
    message = str(info.value)
    assert f"{path}: " in message and reason in message.lower() and "Traceback" not in message
    assert _counts(bpy) == before


def test_good_and_bad_files_together(bpy_empty, testdata, tmp_path, capfd):
    """Three files, the 2nd corrupt: the 1st and 3rd come in, the operator finishes (as
    Blender's own importers do), the bad one is a warning naming it, and nothing of it is
    left half-made. A script tells what failed from the report (printed by bpy)."""
    bpy = bpy_empty
    bad, _ = _truncated(tmp_path, testdata)  # tmp_path/truncated.ply
    for name in ("a.ply", "c.spz"):
        src = "test64.ply" if name.endswith(".ply") else "test64.spz"
        (tmp_path / name).write_bytes((testdata / src).read_bytes())
    capfd.readouterr()
    result = bpy.ops.import_scene.splatline_gaussians(
        directory=str(tmp_path), files=[{"name": "a.ply"}, {"name": bad.name}, {"name": "c.spz"}])
    assert result == {"FINISHED"}
    assert _counts(bpy) == (2, 2, 0)
    assert sorted(o.name for o in bpy.data.objects) == ["a", "c"]
    assert sorted(p.name for p in bpy.data.pointclouds) == ["a", "c"]
    out = capfd.readouterr()
    report = out.out + out.err
    assert f"{bad}: truncated" in report and "1 file(s) failed" in report, report
    with pytest.raises(RuntimeError, match="truncated.ply: truncated"):  # all bad: still an error
        bpy.ops.import_scene.splatline_gaussians(directory=str(tmp_path), files=[{"name": bad.name}])
    assert _counts(bpy) == (2, 2, 0)


def test_nothing_left_when_options_select_nothing(bpy_empty, testdata):
    from addon.blender.data.files import import_file

    with pytest.raises(SplatFormatError, match="no splats left"):
        import_file(bpy_empty.context, testdata / "test64.ply", min_opacity=1.0 + 1e-6)
    assert _counts(bpy_empty) == (0, 0, 0)


def test_failure_inside_blender_build_leaves_nothing(bpy_empty, testdata):
    """A failure after the mesh, helper object and PointCloud exist (linking into a removed
    collection) is cleaned up too."""
    from addon.blender.data.files import import_file

    bpy = bpy_empty
    gone = bpy.data.collections.new("gone")
    bpy.data.collections.remove(gone)
    with pytest.raises(ReferenceError):
        import_file(bpy.context, testdata / "test64.ply", collection=gone)
    assert _counts(bpy) == (0, 0, 0)


def test_nan_and_zero_quaternions_by_policy(bpy_empty, tmp_path):
    """NaN/Inf splats and zero quaternions are counted; the policy neutralises, drops or
    refuses them, and a refusal leaves nothing behind."""
    import numpy as np

    from addon.blender.data.files import import_file_with_report
    from addon.core import formats
    from testing.synth import random_splats

    splats = random_splats(20, 1, seed=5)
    splats.positions[3, 1] = np.nan
    splats.sh_rest[7, 2, 0] = np.inf
    splats.rotations[11] = 0.0
    path = tmp_path / "bad_values.ply"
    formats.write(path, splats)
    bpy = bpy_empty
    obj, report = import_file_with_report(bpy.context, path, bad="fix")
    assert (report.bad.nonfinite, report.bad.zero_quaternions) == (2, 1)
    opacity = np.empty(80, np.float32)
    base = obj.data.attributes["radiance:base"]
    base.data.foreach_get(value_field(base), opacity)
    assert len(obj.data.points) == 20 and opacity[3::4][[3, 7]].tolist() == [0.0, 0.0]
    obj, report = import_file_with_report(bpy.context, path, bad="drop")
    assert len(obj.data.points) == 17
    before = _counts(bpy)
    with pytest.raises(SplatFormatError, match="bad_values.ply: 2 splats with NaN/Inf"):
        import_file_with_report(bpy.context, path, bad="error")
    assert _counts(bpy) == before
    # the operator: a warning (not an error) when neutralising, an error when refusing
    assert bpy.ops.import_scene.splatline_gaussians(filepath=str(path), bad_values="fix") == {"FINISHED"}
    with pytest.raises(RuntimeError, match="bad_values.ply: 2 splats with NaN/Inf"):
        bpy.ops.import_scene.splatline_gaussians(filepath=str(path), bad_values="error")


def test_blenders_copy_of_the_splats_is_checked_against_the_budget(bpy_empty, tmp_path):
    """The memory budget counts what the PointCloud will hold (every attribute as
    float32, pointcloud.blender_bytes) before creating it, on top of the splats reading
    holds. A budget that the reading fits into, with 16 MiB to spare, refuses Blender's
    copy in one line, and nothing is created; without the budget the file imports."""
    import gc

    from addon.blender.data.files import import_file
    from addon.core import budget
    from addon.core.formats import write
    from addon.core.formats._common import splat_bytes
    from testing.synth import random_splats

    count = 300_000
    path = tmp_path / "big.ply"
    write(str(path), random_splats(count, degree=3, seed=1))
    gc.collect()
    budget.set_max_memory(budget.resident() + splat_bytes(count, 45) + (16 << 20))
    try:
        with pytest.raises(SplatFormatError, match=r"big\.ply: would take .*300000 splats of SH "
                                                   r"degree 3 as Blender attributes.*--max-memory"):
            import_file(bpy_empty.context, path)
    finally:
        budget.set_max_memory(None)
    assert _counts(bpy_empty) == (0, 0, 0)
    obj = import_file(bpy_empty.context, path)
    assert len(obj.data.points) == count
