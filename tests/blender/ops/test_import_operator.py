"""Blender import of SOG and glTF splats: operator, FileHandler extensions, plain glTF refused."""
from __future__ import annotations

import json

import numpy as np
import pytest

from addon.blender.data.pointcloud import value_key
from addon.core import formats
from testing.webp_support import needs_straight_webp


@needs_straight_webp
@pytest.mark.parametrize("name,obj_name", [("guitar.sog", "guitar"), ("test64.glb", "test64"),
                                           ("test64_sog_unbundled/meta.json", "test64_sog_unbundled")])
def test_operator_imports_sog_and_glb(bpy_empty, testdata, name, obj_name):
    bpy = bpy_empty
    assert bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / name)) == {"FINISHED"}
    obj = bpy.data.objects[obj_name]
    assert len(obj.data.points) == formats.read(testdata / name).count
    base = np.zeros(len(obj.data.points) * 4, np.float32)
    attribute = obj.data.attributes["radiance:base"]  # FLOAT4 on 5.1+, FLOAT_COLOR before
    attribute.data.foreach_get(value_key(attribute), base)
    assert np.isfinite(base).all()


def test_plain_gltf_is_left_to_blender(bpy_empty, tmp_path):
    bpy = bpy_empty
    plain = tmp_path / "cube.gltf"
    plain.write_text(json.dumps({"asset": {"version": "2.0"}, "scenes": [{"nodes": []}], "scene": 0}))
    handler = bpy.types.FileHandler.bl_rna_get_subclass_py("IO_FH_splatline_gaussians")
    assert not {".glb", ".gltf"} & set(handler.bl_file_extensions.split(";"))
    with pytest.raises(RuntimeError, match="glTF importer"):
        bpy.ops.import_scene.splatline_gaussians(filepath=str(plain))
    assert len(bpy.data.objects) == 0
