"""Blender 5.3's own splat imports (wm.ply_import, wm.spz_import) written to every format
Splatline writes, from File > Export and from `python -m addon convert SCENE.blend --object
NAME OUT`: Blender 5.3 itself exports no splats (its PLY exporter writes 0 points).

The frame of the data (data/files.object_axes): a wm.ply_import object holds the PLY's own
values (RDF) and is written back unchanged; a wm.spz_import object holds Blender's frame
(RFU: Blender reads the SPZ as RUB and turns it), which the caller says (Data Axes, --axes),
since nothing on the object tells the two importers apart.

Skipped where Blender has no native splats (4.5 .. 5.2): there is nothing to export; the
command's .blend input itself (a Splatline import) is tested on every Blender."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from addon.core import formats
from testing.paths import REPO as ROOT
from testing.format_steps import assert_sog_within_steps, assert_spz_within_steps, sog_meta
from testing.webp_support import needs_straight_webp

pytestmark = pytest.mark.usefixtures("bpy_empty")

FIELDS = ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")
CAPTURES = ["guitar.ply", "test64.ply"]  # degree 0, 90,854 splats; degree 3, 64 splats
# Against the file: Blender's own import moves rot_0..3 by up to 1.19e-7 (measured: its
# stored quaternions differ from the file's by that much) and takes the sigmoid of the
# opacity in its own float32 arithmetic, so these two are equal to float32 rounding
# (measured 1.19e-7 and 5.96e-8 at most); every other field reads back bit for bit.
ROTATION_ATOL = 2.0 ** -22  # two float32 ulps of 1.0
OPACITY_ATOL = 2.0 ** -23  # two float32 ulps of 0.5..1


def _blender_import(bpy, path):
    """Blender's own importer, the object it made selected alone (as File > Export sees it)."""
    op = "ply_import" if path.suffix == ".ply" else "spz_import"
    assert getattr(bpy.ops.wm, op)(filepath=str(path)) == {"FINISHED"}
    obj = bpy.context.view_layer.objects.active
    assert obj.type == "POINTCLOUD" and obj.data.type == "GAUSSIAN_SPLAT"
    assert "splatline_axes" not in obj  # nothing of Splatline's on it
    for other in bpy.context.selected_objects:
        other.select_set(False)
    obj.select_set(True)
    return obj


def _export(bpy, path, key, **options):
    """File > Export > Gaussian Splats, the real operator."""
    assert bpy.ops.export_scene.splatline_gaussians(filepath=str(path), file_format=key, **options) == {"FINISHED"}
    return path


def assert_same_as_file(back, src):
    assert back.count == src.count and back.sh_degree == src.sh_degree and back.axes == src.axes == "RDF"
    for field in ("positions", "scales", "sh_dc", "sh_rest"):
        assert np.array_equal(getattr(back, field), getattr(src, field)), field
    assert np.abs(back.rotations - src.rotations).max() <= ROTATION_ATOL
    assert np.abs(back.opacities - src.opacities).max() <= OPACITY_ATOL


@pytest.mark.parametrize("name", CAPTURES)
def test_blenders_ply_import_exports_to_ply_as_the_file_holds_it(native_bpy, testdata, tmp_path, name):
    bpy = native_bpy
    _blender_import(bpy, testdata / name)
    back = formats.read(_export(bpy, tmp_path / "o.ply", "PLY"))
    assert_same_as_file(back, formats.read(testdata / name))


@pytest.mark.parametrize("name", CAPTURES)
@pytest.mark.parametrize("key,ext", [("SPZ", ".spz"), pytest.param("SOG", ".sog", marks=needs_straight_webp)])
def test_blenders_ply_import_exports_to_spz_and_sog_within_their_steps(native_bpy, testdata, tmp_path,
                                                                        name, key, ext):
    bpy = native_bpy
    _blender_import(bpy, testdata / name)
    out = _export(bpy, tmp_path / f"o{ext}", key)
    src = formats.read(testdata / name)
    if key == "SPZ":
        assert_spz_within_steps(formats.read(out), src)
    else:
        assert_sog_within_steps(formats.read(out), src, sog_meta(out))


@pytest.mark.parametrize("key,ext", [("PLY", ".ply"), ("COMPRESSED_PLY", ".compressed.ply"),
                                     ("SPLAT", ".splat"), ("SPZ", ".spz"),
                                     pytest.param("SOG", ".sog", marks=needs_straight_webp),
                                     ("GLB", ".glb"), ("GLTF", ".gltf")])
def test_blenders_ply_import_exports_to_every_format(native_bpy, testdata, tmp_path, key, ext):
    """Every writer: the file holds the capture as Splatline's own write of the .ply gives
    it. Blender keeps the positions bit for bit, so each format's decoded positions (however
    quantised) are the very ones the same writer gives for the file's splats."""
    bpy = native_bpy
    _blender_import(bpy, testdata / "test64.ply")
    back = formats.read(_export(bpy, tmp_path / f"o{ext}", key))
    src = formats.read(testdata / "test64.ply")
    formats.write(tmp_path / f"ref{ext}", src)
    ref = formats.read(tmp_path / f"ref{ext}")
    assert back.count == ref.count == 64 and back.sh_degree == ref.sh_degree
    assert back.sh_degree == min(src.sh_degree, formats.WRITE_MAX_DEGREE[formats.format_for_output(f"x{ext}")])
    assert np.array_equal(back.positions, ref.positions)


def _cli_convert(*args):
    return subprocess.run([sys.executable, "-m", "addon", "convert", *map(str, args)], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


def _save_blend(bpy, path):
    assert bpy.ops.wm.save_as_mainfile(filepath=str(path)) == {"FINISHED"}
    return path


def test_cli_converts_blenders_own_imports_from_a_blend(native_bpy, testdata, tmp_path):
    bpy = native_bpy
    _blender_import(bpy, testdata / "guitar.ply")
    spz_object = _blender_import(bpy, testdata / "test64.spz")
    blend = _save_blend(bpy, tmp_path / "scene.blend")
    rfu = formats.read(testdata / "test64.spz", axes="RUB")  # as Blender reads it

    run = _cli_convert("--object", "guitar", blend, tmp_path / "g.ply")
    assert run.returncode == 0, run.stderr
    assert f"{blend}:guitar (blend, 90854 splats) -> {tmp_path / 'g.ply'}" in run.stdout
    assert_same_as_file(formats.read(tmp_path / "g.ply"), formats.read(testdata / "guitar.ply"))

    run = _cli_convert("--object", "guitar", blend, tmp_path / "g.spz")
    assert run.returncode == 0, run.stderr
    assert_spz_within_steps(formats.read(tmp_path / "g.spz"), formats.read(testdata / "guitar.ply"))

    # Blender's SPZ import: its frame said with --axes RFU, written in the PLY's
    run = _cli_convert("--object", spz_object.name, "--axes", "RFU", blend, tmp_path / "t.ply")
    assert run.returncode == 0, run.stderr
    _assert_holds_as_blender_read(formats.read(tmp_path / "t.ply"), rfu)

    # a .blend of two splat objects needs --object; an unknown name lists the splat objects
    for args, needle in (([blend, tmp_path / "x.ply"], "holds 2 splat objects: guitar, test64; name one with --object"),
                         (["--object", "nope", blend, tmp_path / "x.ply"], "--object 'nope': no object; its splat objects: guitar, test64")):
        run = _cli_convert(*args)
        lines = [line for line in run.stderr.splitlines() if line.startswith("error:")]
        assert run.returncode == 1 and len(lines) == 1 and needle in lines[0], run.stderr
        assert "Traceback" not in run.stderr and not (tmp_path / "x.ply").exists()


def test_cli_converts_a_splatline_object_from_a_blend(bpy_empty, testdata, tmp_path):
    """The same command on any Blender: a Splatline import in a .blend converts as File >
    Export writes it (its recorded RDF frame), and --object merges objects in the order named."""
    bpy = bpy_empty
    bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "test64.ply"))
    _export(bpy, tmp_path / "menu.ply", "PLY")
    bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "guitar.ply"), max_count=100)
    blend = _save_blend(bpy, tmp_path / "scene.blend")
    run = _cli_convert("--object", "test64", blend, tmp_path / "cli.ply")
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "cli.ply").read_bytes() == (tmp_path / "menu.ply").read_bytes()
    run = _cli_convert("--object", "guitar", "--object", "test64", "--max-sh-degree", "1", blend, tmp_path / "m.ply")
    assert run.returncode == 0, run.stderr
    merged, test64 = formats.read(tmp_path / "m.ply"), formats.read(testdata / "test64.ply")
    assert merged.count == 164 and merged.sh_degree == 1
    assert np.array_equal(merged.positions[100:], test64.positions)
    for args, needle, code in ((["--object", "test64", testdata / "test64.ply", tmp_path / "x.ply"],
                                "--object names splat objects of a .blend input; none was given", 2),
                               ([blend, blend, tmp_path / "x.ply"], "one .blend input at a time, not 2", 2),
                               ([tmp_path / "none.blend", tmp_path / "x.ply"],
                                f"{tmp_path / 'none.blend'}: no such file", 1)):
        run = _cli_convert(*args)
        assert run.returncode == code and run.stderr.startswith("error: ") and needle in run.stderr, run.stderr
        assert len(run.stderr.splitlines()) == 1 and not (tmp_path / "x.ply").exists()


def _assert_holds_as_blender_read(back, rub):
    """back, read from a file written from a wm.spz_import object, holds the SPZ's splats as
    Blender read them (its values in RUB, Blender's frame after its turn), re-expressed in the
    file's RDF: positions bit for bit (quarter turns swap and negate), the rest to the float32
    rounding of two turns (Blender's, then export's) and of two SPZ decoders. Measured on
    guitar_v3/test64: 1 - |dot| of rotations 1.9e-7, opacities 1.5e-8, sh_dc 1.2e-7, sh_rest 6e-8."""
    from addon.core.reframe import reframe

    want = reframe(rub, "RDF")
    assert back.count == want.count and back.sh_degree == want.sh_degree
    np.testing.assert_array_equal(back.positions, want.positions)
    dots = np.abs(np.einsum("ij,ij->i", back.rotations.astype(np.float64), want.rotations))
    assert dots.min() >= 1 - 1e-6
    np.testing.assert_array_equal(back.scales, want.scales)
    np.testing.assert_allclose(back.opacities, want.opacities, rtol=0, atol=OPACITY_ATOL)
    np.testing.assert_allclose(back.sh_dc, want.sh_dc, rtol=0, atol=1e-6)
    np.testing.assert_allclose(back.sh_rest, want.sh_rest, rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", ["guitar_v3.spz", "test64.spz"])
def test_blenders_spz_import_exports_in_the_frame_it_shows(native_bpy, testdata, tmp_path, name):
    """Data Axes RFU: the written .ply holds the SPZ as Blender read it, and a Splatline
    import of it shows what Blender showed: the same world centres and view-dependent colour."""
    from addon.blender.data.pointcloud import splats_from_pointcloud
    from addon.core.sh import sh_to_rgb

    bpy = native_bpy
    obj = _blender_import(bpy, testdata / name)
    out = _export(bpy, tmp_path / "o.ply", "PLY", data_axes="RFU")
    back = formats.read(out)
    _assert_holds_as_blender_read(back, formats.read(testdata / name, axes="RUB"))
    spz = _export(bpy, tmp_path / "o.spz", "SPZ", data_axes="RFU")  # and within SPZ's steps
    assert_spz_within_steps(formats.read(spz), back)

    shown = splats_from_pointcloud(obj.data)  # identity transform: object space is world
    assert bpy.ops.import_scene.splatline_gaussians(filepath=str(out)) == {"FINISHED"}
    ours = bpy.context.view_layer.objects.active
    bpy.context.view_layer.update()
    matrix = np.array(ours.matrix_world, np.float64)
    assert not np.allclose(matrix[:3, :3], np.eye(3))  # the PLY's frame is on the transform
    local = splats_from_pointcloud(ours.data)
    world = local.positions @ matrix[:3, :3].T + matrix[:3, 3]
    np.testing.assert_allclose(world, shown.positions, rtol=0, atol=2e-6)  # measured 1.9e-7
    dirs = np.random.default_rng(0).normal(size=(local.count, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    np.testing.assert_allclose(sh_to_rgb(local.sh_dc, local.sh_rest, dirs @ matrix[:3, :3], local.sh_degree),
                               sh_to_rgb(shown.sh_dc, shown.sh_rest, dirs, shown.sh_degree), rtol=0, atol=1e-6)  # 6.5e-8


@pytest.mark.parametrize("name", ["guitar_v3.spz"])
def test_evaluated_export_of_a_blender_spz_import_takes_data_axes(native_bpy, testdata, tmp_path, name):
    """File > Export > Evaluated Splats writes the same file as File > Export for an object
    without effects, Data Axes included (an SPZ import's data is in Blender's frame)."""
    bpy = native_bpy
    _blender_import(bpy, testdata / name)
    plain = _export(bpy, tmp_path / "plain.ply", "PLY", data_axes="RFU")
    evaluated = tmp_path / "evaluated.ply"
    assert bpy.ops.export_scene.splatline_evaluated(filepath=str(evaluated), data_axes="RFU") == {"FINISHED"}
    assert evaluated.read_bytes() == plain.read_bytes()
    default = tmp_path / "default.ply"
    assert bpy.ops.export_scene.splatline_evaluated(filepath=str(default)) == {"FINISHED"}
    assert default.read_bytes() != evaluated.read_bytes()  # AUTO reads it as a PLY's frame


def test_blenders_ply_import_renders_as_splatlines_own(native_bpy, testdata, tmp_path):
    """Splatline's engine draws Blender's import like Splatline's import of the same file,
    given the same world transform (Splatline puts the PLY's frame on the transform)."""
    from addon.blender.data.pointcloud import read_positions
    from addon.core.axes import euler_for
    from testing.engine_scene import add_camera, read_image, set_output, setup_render

    bpy = native_bpy
    theirs = _blender_import(bpy, testdata / "guitar.ply")
    theirs.rotation_euler = euler_for("RDF")
    assert bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "guitar.ply")) == {"FINISHED"}
    ours = bpy.context.view_layer.objects.active
    bpy.context.view_layer.update()
    assert np.allclose(np.array(theirs.matrix_world), np.array(ours.matrix_world))
    matrix = np.array(ours.matrix_world, np.float64)
    world = read_positions(ours.data) @ matrix[:3, :3].T
    lo, hi = np.percentile(world, [2, 98], axis=0)
    centre, size = (lo + hi) / 2, float(np.linalg.norm(hi - lo))
    add_camera(bpy, location=tuple(centre + (0.3 * size, -1.2 * size, 0.2 * size)), target=tuple(centre))
    scene = setup_render(bpy, 96, 64)
    images = {}
    for shown, drawn, hidden in (("theirs", theirs, ours), ("ours", ours, theirs)):
        drawn.hide_render, hidden.hide_render = False, True
        set_output(scene, "PNG", tmp_path / shown)
        bpy.ops.render.render(write_still=True)
        images[shown] = read_image(tmp_path / f"{shown}.png").astype(np.int16)
    alpha = images["theirs"][..., 3]
    assert (alpha >= 128).mean() > 0.05 and (alpha == 0).any()  # the guitar, framed, drawn (10.5%)
    assert np.abs(images["theirs"] - images["ours"]).max() <= 1  # measured: the same bytes
