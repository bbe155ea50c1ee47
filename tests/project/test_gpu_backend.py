"""The GPU backend a run asks for (SPLATLINE_GPU_BACKEND, testing/gpu_backend.py) is the one
Blender's gpu module runs on, and every test file that draws through the gpu module is
marked to run again on each further backend (the Makefile's GPU_BACKENDS).

Blender falls back quietly (Blender 5.3 without a Vulkan driver starts OpenGL and only logs
"Unable to initialize a Vulkan 1.1 instance"), so without this check a run meant for Vulkan
would pass while testing OpenGL."""
from __future__ import annotations

import pathlib
import re

import pytest
from testing.gpu_backend import GPU_BACKEND, GPU_MODULE_TESTS
from testing.paths import TESTS

# What reaches Blender's gpu module from a test file: the headless start (ensure_gpu, or the
# footprint scenes' gpu_ready fixture), the viewport's offscreen draws, the engine's
# Blender-GPU path, the gpu module itself.
_GPU_USE = re.compile(r"\bensure_gpu\b|\bgpu_ready\b|\bdraw_offscreen\b|\bdraw_camera\b|"
                      r"\bGPU_MODULE\b|\bGPUOffScreen\b|^\s*(import|from) gpu\b", re.M)


@pytest.mark.skipif(GPU_BACKEND is None, reason="SPLATLINE_GPU_BACKEND unset: Blender's default")
def test_blender_gpu_runs_on_the_backend_asked_for(_bpy_registered):
    import gpu

    from testing.headless import ensure_gpu

    ensure_gpu()  # the gpu module is usable from here on: Blender's GPU has started
    got = gpu.platform.backend_type_get()
    hint = (": the bpy module starts Vulkan only where it is Blender's default backend (5.3+) "
            "and a Vulkan driver is installed (.ci/sysdeps.sh installs mesa-vulkan-drivers)"
            if GPU_BACKEND == "VULKAN" else "")
    assert got == GPU_BACKEND, (f"SPLATLINE_GPU_BACKEND={GPU_BACKEND} but Blender's GPU runs on "
                                f"{got} ({gpu.platform.renderer_get()}){hint}")
    off = gpu.types.GPUOffScreen(4, 4)  # and it draws
    off.free()


def test_every_test_file_that_uses_the_gpu_module_is_marked():
    here = pathlib.Path(__file__).resolve()
    uses = {p.relative_to(TESTS).as_posix() for p in TESTS.rglob("test_*.py")
            if p != here and _GPU_USE.search(p.read_text())}
    missing = sorted(uses - GPU_MODULE_TESTS)
    assert not missing, f"add to GPU_MODULE_TESTS in testing/gpu_backend.py: {missing}"
    gone = sorted(n for n in GPU_MODULE_TESTS if not (TESTS / n).is_file())
    assert not gone, f"GPU_MODULE_TESTS in testing/gpu_backend.py names missing files: {gone}"
