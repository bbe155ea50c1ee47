"""Start Blender's GPU in background mode (bpy as a module, blender -b).

The gpu module refuses to draw in background mode until Blender has created its
GPU context. Blender 5.2+ has gpu.init() for that (used where it exists); before it,
rendering one tiny frame with a RenderEngine that asks for a GPU
context (bl_use_gpu_context) creates it, and it stays for the session
(DESIGN.md, "Testing Blender for real, headless").
"""
from __future__ import annotations

import bpy

_IDNAME = "SPLATLINE_GPU_INIT"


class _GpuInitEngine(bpy.types.RenderEngine):
    bl_idname = _IDNAME
    bl_label = "Splatline GPU init"
    bl_use_gpu_context = True

    def render(self, depsgraph):
        result = self.begin_result(0, 0, 1, 1)
        self.end_result(result)


def gpu_ready() -> bool:
    import gpu

    try:
        gpu.platform.backend_type_get()
        gpu.types.GPUOffScreen(1, 1).free()
        return True
    except Exception:
        return False


def ensure_gpu() -> None:
    """Make the gpu module usable; a no-op when it already is (UI sessions, repeat calls)."""
    if not bpy.app.background or gpu_ready():
        return
    import gpu

    if hasattr(gpu, "init"):  # Blender 5.2+: the API for this; raises SystemError on failure
        gpu.init()
        return
    scene = bpy.data.scenes.new("splatline_gpu_init")
    cam_data = bpy.data.cameras.new("splatline_gpu_init")
    cam = bpy.data.objects.new("splatline_gpu_init", cam_data)
    registered = False
    try:
        scene.collection.objects.link(cam)
        scene.camera = cam
        bpy.utils.register_class(_GpuInitEngine)
        registered = True
        scene.render.engine = _IDNAME
        scene.render.resolution_x = scene.render.resolution_y = 4
        with bpy.context.temp_override(scene=scene):
            bpy.ops.render.render(scene=scene.name)
    finally:
        bpy.data.scenes.remove(scene)
        bpy.data.objects.remove(cam)
        bpy.data.cameras.remove(cam_data)
        if registered:
            bpy.utils.unregister_class(_GpuInitEngine)
