"""Shared fixtures. Core tests need no bpy; blender tests use the real bpy module."""
from __future__ import annotations

import os
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


def _bundled_site_packages():
    """Blender's bundled Python packages (OpenImageIO, ...) shipped inside the bpy wheel."""
    import importlib.util

    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        return None
    base = pathlib.Path(list(spec.submodule_search_locations)[0])
    hits = sorted(base.glob("*/python/lib/python3.*/site-packages"))
    return hits[0] if hits else None


_site = _bundled_site_packages()
if _site is not None and str(_site) not in sys.path:
    sys.path.append(str(_site))  # appended: the venv's own numpy must win
