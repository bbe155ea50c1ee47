"""Fixtures the viewport's tests share."""
from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def gpu_ready(_bpy_registered):
    """Blender's GPU started in this process (testing/headless.py): the gpu module works."""
    from testing.headless import ensure_gpu

    ensure_gpu()
    return True
