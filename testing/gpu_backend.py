"""Which Blender GPU backend a test run asks for, and which test files draw through Blender's
gpu module (tests/conftest.py marks them; tests/project/test_gpu_backend.py checks the list)."""
from __future__ import annotations

import os

# SPLATLINE_GPU_BACKEND=VULKAN|OPENGL (the Makefile sets it; unset means Blender's default).
GPU_BACKENDS = ("VULKAN", "OPENGL")
GPU_BACKEND = os.environ.get("SPLATLINE_GPU_BACKEND", "").strip().upper() or None

# Test files that draw through Blender's gpu module (viewport drawing, the engine's
# Blender-GPU path), as paths under tests/: marked gpu_module, they run once more on every
# further backend a Blender version is tested on (the Makefile's GPU_BACKENDS).
GPU_MODULE_TESTS = frozenset({
    "core/effects/test_effects_kinds.py",
    "blender/render/test_engine_gpu.py",
    "blender/render/test_engine_paths.py",
    "core/test_footprint.py",
    "project/test_gpu_backend.py",
    "core/test_tie_order.py",
    "blender/viewport/test_viewport.py",
    "blender/viewport/test_viewport_blender.py",
    "blender/viewport/test_viewport_declared_path.py",
    "blender/viewport/test_viewport_lighting.py",
    "blender/evaluate/test_splat_sources.py",
    "blender/viewport/test_viewport_display_modes.py",
    "blender/viewport/test_viewport_effects.py",
    "blender/viewport/test_viewport_displace.py",
    "blender/viewport/test_viewport_memory.py",
    "blender/viewport/test_viewport_speed_paths.py",
    "blender/viewport/test_viewport_instances.py",
})
