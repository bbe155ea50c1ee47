"""File > Export > Gaussian Splats offers every writer; each file reads back whole."""
from __future__ import annotations

import pytest

from addon.core import formats
from testing.webp_support import needs_straight_webp

CASES = [("PLY", "o.ply", "ply"), ("COMPRESSED_PLY", "o.compressed.ply", "compressed_ply"),
         ("SPLAT", "o.splat", "splat"), ("SPZ", "o.spz", "spz"), pytest.param("SOG", "o.sog", "sog", marks=needs_straight_webp),
         ("GLB", "o.glb", "glb"), ("GLTF", "o.gltf", "gltf")]


def test_export_menu_offers_every_writer(bpy_empty):
    from addon.blender.ops.io import _EXPORT_EXT

    assert {formats.format_for_output("x" + ext) for ext in _EXPORT_EXT.values()} == set(formats.WRITE_FORMATS)
    rna = bpy_empty.ops.export_scene.splatline_gaussians.get_rna_type()
    assert {item.identifier for item in rna.properties["file_format"].enum_items} == set(_EXPORT_EXT)


@pytest.mark.parametrize("key,name,fmt", CASES)
def test_export_operator_each_format(bpy_empty, testdata, tmp_path, key, name, fmt):
    bpy = bpy_empty
    bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "test64.ply"))
    # the format, not the typed extension, names the file
    assert bpy.ops.export_scene.splatline_gaussians(filepath=str(tmp_path / "o.ply"), file_format=key) == {"FINISHED"}
    out = tmp_path / name
    assert formats.detect_format(out) == ("glb" if fmt == "gltf" else fmt) or fmt == "gltf"
    back = formats.read(out)
    assert back.count == 64 and back.sh_degree == (0 if fmt == "splat" else 3)
