"""The installable extension: built with Blender's own builder, installed through Blender's
extension API into a fresh user folder, enabled, then used to import and render."""
from __future__ import annotations

import os
import subprocess
import sys
import zipfile

import pytest

from testing.paths import REPO as ROOT

INSTALL_AND_RENDER = r"""
import importlib.machinery, site, sys


class WheelsOnly:
    # The venv has its own moderngl, glcontext and plyfile: hide those, so that what gets
    # imported is what the extension's wheels installed for this Python (plyfile: none, so
    # an add-on import of it fails here).
    venv = set(site.getsitepackages())

    @classmethod
    def find_spec(cls, name, path=None, target=None):
        if path is None and name in {"moderngl", "_moderngl", "glcontext", "plyfile"}:
            spec = importlib.machinery.PathFinder.find_spec(
                name, [p for p in sys.path if p not in cls.venv])
            if spec is None:
                raise ModuleNotFoundError(name + ": not installed by the extension", name=name)
            return spec


sys.meta_path.insert(0, WheelsOnly)
import bpy
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
if hasattr(scene.render.image_settings, "media_type"):  # Blender 5.0+: set before file_format
    scene.render.image_settings.media_type = "IMAGE"
scene.render.image_settings.file_format = "PNG"
scene.render.image_settings.color_mode = "RGBA"
scene.render.filepath = out_png
bpy.ops.render.render(write_still=True)
import moderngl
print("MODERNGL", moderngl.__file__, sys.version_info[:2], bpy.app.version_string)
print("INSTALLED", [m for m in bpy.context.preferences.addons.keys() if "splatline" in m])
"""


PLATFORM_WHEELS = {  # platform suffix of each zip -> platform tag of its wheels, Python tags
    "linux_x64": ("manylinux2014_x86_64", {"cp311", "cp313"}),
    "windows_x64": ("win_amd64", {"cp311", "cp313"}),
    "macos_arm64": ("macosx_11_0_arm64", {"cp311", "cp313"}),
    "macos_x64": ("macosx_10_9_x86_64", {"cp311"}),  # Blender 4.5 LTS is the last for Intel Macs
}


def _blender_ext(python: str) -> str:
    out = subprocess.run([python, "-c", "import bpy, os; print(os.path.join(bpy.utils.system_resource("
                          "'SCRIPTS'), 'addons_core/bl_pkg/cli/blender_ext.py'))"],
                         capture_output=True, text=True, check=True).stdout
    return out.strip().splitlines()[-1]


@pytest.fixture(scope="module")
def extension_zips(tmp_path_factory):
    out = tmp_path_factory.mktemp("dist")
    proc = subprocess.run(["bash", str(ROOT / ".ci" / "build_extension.sh"), sys.executable, str(out)],
                          cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    return {z.stem.split("-")[-1]: z for z in out.glob("splatline-*.zip")}


def test_one_zip_per_platform(extension_zips):
    assert set(extension_zips) == set(PLATFORM_WHEELS)
    ext = _blender_ext(sys.executable)
    for platform, zip_path in extension_zips.items():
        names = zipfile.ZipFile(zip_path).namelist()
        assert "blender_manifest.toml" in names and "__init__.py" in names
        assert any(n.startswith("addon/core/") for n in names)
        assert any(n.startswith("shaders/") and n.endswith(".glsl") for n in names)
        # Nothing from development gets shipped.
        assert not any(n.startswith(("tests/", "bench/", ".venv/", ".git/", "wheels/.", "build/"))
                       or n == "pyproject.toml" or ".egg-info/" in n for n in names)
        # Wheels for this platform only, one per Python the platform's Blenders run.
        wheels = [n.split("/", 1)[1][:-4].split("-") for n in names if n.startswith("wheels/")]
        tag, pythons = PLATFORM_WHEELS[platform]
        # (no plyfile: the add-on reads PLY itself, docs/DESIGN.md)
        assert sorted((w[0], w[2]) for w in wheels) == sorted(
            (name, py) for name in ("glcontext", "moderngl") for py in pythons), platform
        assert all(tag in w[4].split(".") for w in wheels), platform
        # Blender's own builder accepts the built zip as it is.
        proc = subprocess.run([sys.executable, ext, "validate", str(zip_path)],
                              capture_output=True, text=True)
        assert proc.returncode == 0, proc.stdout + proc.stderr


def _test_only_modules() -> set[str]:
    """File names of the test-support modules (testing/), wherever they might be shipped."""
    names = {p.name for p in (ROOT / "testing").rglob("*.py") if p.name != "__init__.py"}
    assert {"synth.py", "headless.py"} <= names, "testing/ lost its generators"
    return names


def test_zip_holds_no_test_only_module(extension_zips):
    test_only = _test_only_modules()
    product = {p.relative_to(ROOT).as_posix() for folder in ("addon", "presets")
               for p in (ROOT / folder).rglob("*.py")}
    for platform, zip_path in extension_zips.items():
        modules = [n for n in zipfile.ZipFile(zip_path).namelist() if n.endswith(".py")]
        assert not [n for n in modules if n.startswith("testing/")
                    or n.rsplit("/", 1)[-1] in test_only], platform
        # Python goes in only as the add-on, its presets and the zip's own __init__.py.
        assert set(modules) == product | {"__init__.py"}, platform


def _venvs():
    """The Python running pytest, and the venv of the other Blender Python (3.11 <-> 3.13)."""
    other = ROOT / (".venv-5.2" if sys.version_info[:2] == (3, 11) else ".venv") / "bin" / "python"
    return [pytest.param(sys.executable, id="this-python"), pytest.param(str(other), id="other-python")]


@pytest.mark.parametrize("python", _venvs())
def test_install_enable_import_render(python, extension_zips, testdata, tmp_path):
    if not os.path.exists(python):
        pytest.skip(f"{python} is missing: build it with `make test BLENDER="
                    f"{'5.2' if '.venv-5.2' in python else '5.0'}` to test that Blender's Python too")
    script = tmp_path / "install.py"
    script.write_text(INSTALL_AND_RENDER)
    out_png = tmp_path / "frame.png"
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp_path / "user"))
    env.pop("PYTHONPATH", None)
    # Run from tmp_path so the repo's own `addon` package cannot shadow the installed one.
    proc = subprocess.run([python, str(script), str(extension_zips["linux_x64"]),
                           str(testdata / "guitar.spz"), str(out_png)],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "bl_ext.user_default.splatline" in proc.stdout
    # moderngl came from the extension's own wheel, the one built for this Blender's Python.
    assert "/extensions/.local/lib/python" in proc.stdout.split("MODERNGL ", 1)[1].splitlines()[0]
    import OpenImageIO as oiio

    pixels = oiio.ImageBuf(str(out_png)).get_pixels(oiio.FLOAT)
    assert pixels.shape == (64, 96, 4)
    alpha = pixels[..., 3]
    assert 0.01 < (alpha > 0.5).mean() < 0.99, "the capture should cover part of the frame"


INSTALL_AND_EXIT = r"""
import sys
import bpy
zip_path, capture = sys.argv[-2:]
bpy.ops.wm.read_factory_settings(use_empty=True)
result = bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                                  enable_on_install=True)
assert result == {"FINISHED"}, result
name = "bl_ext.user_default.splatline"
assert name in bpy.context.preferences.addons.keys()
bpy.ops.import_scene.splatline_gaussians(filepath=capture)
# Off and on again through Blender, as a user would in Preferences: each way is clean too.
bpy.ops.preferences.addon_disable(module=name)
assert not hasattr(bpy.types, "SPLATLINE_MT_object")
bpy.ops.preferences.addon_enable(module=name)
assert hasattr(bpy.types, "SPLATLINE_MT_object")
print("ENABLED", name)
"""


def test_exit_after_installing_the_zip_is_clean(extension_zips, testdata, tmp_path):
    # Installed and enabled through Blender's extension API, the add-on is torn down at exit
    # both by its own atexit hook and by Blender's (addon_utils.disable_all): the second pass
    # used to print `Exception in module unregister()` and a RuntimeError on
    # SPLATLINE_MT_object at every exit (bpy 4.5, 5.0, 5.2, 5.3).
    script = tmp_path / "install_and_exit.py"
    script.write_text(INSTALL_AND_EXIT)
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp_path / "user"))
    env.pop("PYTHONPATH", None)
    proc = subprocess.run([sys.executable, str(script), str(extension_zips["linux_x64"]),
                           str(testdata / "test64.ply")],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "ENABLED bl_ext.user_default.splatline" in proc.stdout
    for stream in (proc.stdout, proc.stderr):  # Blender prints the first line to stdout
        assert "Traceback" not in stream and "Exception in module unregister" not in stream, stream[-3000:]
