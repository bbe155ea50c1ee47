"""The installable extension: built with Blender's own builder, installed through Blender's
extension API into a fresh user folder, enabled, then used to import and render."""
from __future__ import annotations

import os
import subprocess
import sys
import zipfile

import pytest

from conftest import ROOT

INSTALL_AND_RENDER = r"""
import sys, bpy
zip_path, capture, out_png = sys.argv[-3:]
bpy.ops.wm.read_factory_settings(use_empty=True)
result = bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                                  enable_on_install=True)
assert result == {"FINISHED"}, result
assert "bl_ext.user_default.splatline" in bpy.context.preferences.addons.keys()
bpy.ops.import_scene.splatline_gaussians(filepath=capture)
obj = bpy.context.active_object
assert obj.type == "POINTCLOUD" and len(obj.data.points) == 90854
import numpy as np
local = np.empty(len(obj.data.points) * 3, np.float32)
obj.data.attributes["position"].data.foreach_get("vector", local)
world = np.asarray(obj.matrix_world)
points = local.reshape(-1, 3) @ world[:3, :3].T + world[:3, 3]
centre = np.median(points, axis=0)
radius = float(np.percentile(np.linalg.norm(points - centre, axis=1), 90))
camera = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
bpy.context.scene.collection.objects.link(camera)
bpy.context.scene.camera = camera
camera.location = tuple(centre + np.array([0.0, -3.0 * radius, 0.0]))
camera.rotation_euler = (np.pi / 2, 0.0, 0.0)  # looks along +y, at the capture
scene = bpy.context.scene
scene.render.engine = "SPLATLINE"
scene.render.resolution_x, scene.render.resolution_y = 96, 64
scene.render.resolution_percentage = 100
scene.render.film_transparent = True
from bl_ext.user_default.splatline.addon.blender.compat import set_file_format  # shipped in the zip
set_file_format(scene.render.image_settings, "PNG")
scene.render.image_settings.color_mode = "RGBA"
scene.render.filepath = out_png
bpy.ops.render.render(write_still=True)
print("INSTALLED", [m for m in bpy.context.preferences.addons.keys() if "splatline" in m])
"""


@pytest.fixture(scope="module")
def extension_zip(tmp_path_factory):
    out = tmp_path_factory.mktemp("dist")
    subprocess.run(["bash", str(ROOT / ".ci" / "build_extension.sh"), sys.executable, str(out)],
                   cwd=ROOT, check=True, capture_output=True, text=True)
    (zip_path,) = out.glob("splatline-*.zip")
    return zip_path


def test_zip_layout(extension_zip):
    names = zipfile.ZipFile(extension_zip).namelist()
    assert "blender_manifest.toml" in names and "__init__.py" in names
    assert any(n.startswith("addon/core/") for n in names)
    assert any(n.startswith("shaders/") and n.endswith(".glsl") for n in names)
    wheels = {n.split("/")[1].split("-")[0] for n in names if n.startswith("wheels/")}
    assert wheels == {"plyfile", "moderngl", "glcontext"}
    # Nothing from development gets shipped.
    assert not any(n.startswith(("tests/", "bench/", ".venv/", ".git/")) for n in names)


def test_install_enable_import_render(extension_zip, testdata, tmp_path):
    script = tmp_path / "install.py"
    script.write_text(INSTALL_AND_RENDER)
    out_png = tmp_path / "frame.png"
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp_path / "user"))
    # Run from tmp_path so the repo's own `addon` package cannot shadow the installed one.
    proc = subprocess.run([sys.executable, str(script), str(extension_zip),
                           str(testdata / "guitar.spz"), str(out_png)],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "bl_ext.user_default.splatline" in proc.stdout
    import OpenImageIO as oiio

    pixels = oiio.ImageBuf(str(out_png)).get_pixels(oiio.FLOAT)
    assert pixels.shape == (64, 96, 4)
    alpha = pixels[..., 3]
    assert 0.01 < (alpha > 0.5).mean() < 0.99, "the capture should cover part of the frame"
