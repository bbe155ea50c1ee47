"""One scene rendered through each engine path (bpy.ops.render.render), and the reference.

Used by tests/blender/render/test_engine_paths.py and bench/engine_paths_bench.py.
"""
from __future__ import annotations

import time

import numpy as np

from .engine_scene import add_camera, add_splats, read_exr_parts, set_output, setup_render
from .viewport_scene import two_objects


def two_object_scene(bpy, testdata, width=160, height=120, transparent=True):
    """test64.ply and a rotated, non-uniformly scaled degree-1 blob interleaved in depth
    (viewport_scene.two_objects), as real splat objects, seen by the scene camera."""
    from mathutils import Matrix

    items, centre = two_objects(testdata)
    for k, item in enumerate(items):
        obj = add_splats(bpy, f"splats{k}", item.splats)
        obj.matrix_world = Matrix(item.world.tolist())
    eye = np.asarray(centre) + np.array([0.35, -0.9, 0.3])
    add_camera(bpy, location=tuple(eye), target=tuple(centre))
    scene = setup_render(bpy, width, height, transparent=transparent)
    bpy.context.view_layer.update()
    return scene


def render_exr(bpy, scene, path, kind, depth=True):
    """Combined and Depth (None with depth=False) of one still through `kind`, and the
    seconds it took."""
    scene.splatline.render.renderer = kind
    set_output(scene, "EXR", path)  # a multilayer EXR: it turns the Z pass on
    for layer in scene.view_layers:
        layer.use_pass_z = depth
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    seconds = time.perf_counter() - start
    parts = read_exr_parts(path.with_suffix(".exr"))
    depth = parts.get("ViewLayer.Depth")
    return parts["ViewLayer.Combined"], None if depth is None else depth[..., 0], seconds


def reference_frame(bpy, scene):
    """The float64 reference of the same evaluated scene, region and options."""
    from addon.blender.render.camera import camera_from_blender
    from addon.blender.evaluate.items import collect_items
    from addon.blender.render.film import region_camera, render_region
    from addon.core import reference

    depsgraph = bpy.context.evaluated_depsgraph_get()
    full = camera_from_blender(scene, scene.camera, depsgraph)
    r = scene.render
    region = render_region(full.width, full.height, r.use_border,
                           (r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y))
    return reference.render(collect_items(depsgraph), region_camera(full, region),
                            scene.splatline.render.options())


def to_display(linear):
    """The engine's scene-linear film back in the renderers' space: premultiplied sRGB."""
    from addon.core.colorspace import linear_to_srgb

    alpha = linear[..., 3:]
    straight = np.divide(linear[..., :3], alpha, out=np.zeros_like(linear[..., :3]),
                         where=alpha > 0)
    return np.concatenate([linear_to_srgb(straight) * alpha, alpha], axis=-1)
