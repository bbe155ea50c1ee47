"""Shared fixtures. Core tests need no bpy; blender tests use the real bpy module."""
from __future__ import annotations

import pathlib
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
TESTDATA = ROOT.parent / "shared" / "testdata"
sys.path.insert(0, str(ROOT))


@pytest.fixture(scope="session")
def testdata() -> pathlib.Path:
    """The read-only real captures (never write here)."""
    if not TESTDATA.is_dir():
        pytest.fail(f"missing {TESTDATA}: the repo expects ../shared/testdata beside it")
    return TESTDATA


@pytest.fixture(scope="module")
def renderer():
    """One offscreen GL renderer per test module (a context and its GL thread); modules
    that need another kind define their own."""
    from addon.gl import OffscreenRenderer

    r = OffscreenRenderer()
    yield r
    r.close()


@pytest.fixture(scope="session")
def _bpy_registered():
    import bpy

    from addon import register

    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy.types.Object, "splatline"):
        register()
    return bpy


@pytest.fixture
def bpy_empty(_bpy_registered):
    """Real bpy with Splatline registered and an empty scene for each test."""
    bpy = _bpy_registered
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy.types.Object, "splatline"):
        from addon import register

        register()
    return bpy


# Blender's bundled Python packages (OpenImageIO, ...) inside the bpy wheel: found the way the
# command line finds them (core's webp module), appended so the venv's own numpy wins.
from addon.core.formats.webp import _bundled_site_packages  # noqa: E402

_site = _bundled_site_packages()
if _site is not None and _site not in sys.path:
    sys.path.append(_site)
