"""holdout_scenes.guitar_scene built in Blender with real mesh objects.

guitar.ply imported as the UI imports it (its RDF axes on the object), a camera whose
projection is the scene's (50 degrees across, clip start/end as the core camera), the two
cubes from bpy.ops.mesh.primitive_cube_add and the tilted rectangle from
primitive_plane_add with its four corners moved onto the scene's, each with a material of
its own viewport colour (what Workbench draws). The Splatline engine with the offscreen GL
renderer, a transparent film, Standard view (engine_scene.setup_render).
"""
from __future__ import annotations

import math

import numpy as np

from .engine_scene import setup_render
from .holdout_scenes import guitar_scene

# Viewport colours (Workbench draws them, lit by its studio light)
COLOURS = {"front_cube": (0.1, 0.9, 0.1, 1.0), "back_cube": (0.1, 0.2, 0.95, 1.0),
           "plane": (0.9, 0.9, 0.1, 1.0)}


def add_camera_for(bpy, camera, name="Camera"):
    """A Blender camera rendering exactly core `camera` (a simple_camera: square pixels,
    centred, fov from fx): horizontal sensor fit, lens from fx."""
    scene = bpy.context.scene
    data = bpy.data.cameras.new(name)
    data.sensor_fit = "HORIZONTAL"
    data.sensor_width = 36.0
    data.lens = camera.fx * 36.0 / camera.width
    data.clip_start, data.clip_end = camera.near, camera.far
    obj = bpy.data.objects.new(name, data)
    scene.collection.objects.link(obj)
    from mathutils import Matrix

    obj.matrix_world = Matrix(np.linalg.inv(camera.world_to_camera).tolist())
    scene.camera = obj
    return obj


def _material(bpy, name, colour):
    mat = bpy.data.materials.new(name)
    mat.diffuse_color = colour
    if "use_nodes" in mat.bl_rna.properties and not getattr(mat.bl_rna.properties["use_nodes"],
                                                            "is_deprecated", False):
        mat.use_nodes = True
    principled = next((n for n in (mat.node_tree.nodes if mat.node_tree else ())
                       if n.bl_idname == "ShaderNodeBsdfPrincipled"), None)
    if principled is not None:  # EEVEE and Cycles draw this one
        principled.inputs["Base Color"].default_value = colour
    return mat


def add_meshes(bpy, meshes):
    """{name: object} of the scene's surfaces as real primitives."""
    objects = {}
    for name, (verts, faces) in meshes.items():
        verts = np.asarray(verts, np.float64)
        if name.endswith("cube"):
            centre = verts.mean(0)
            half = verts.max(0) - centre
            assert np.allclose(half, half[0]), "the scene's cubes are cubes"
            bpy.ops.mesh.primitive_cube_add(size=2.0 * float(half[0]), location=tuple(centre))
            obj = bpy.context.object
        else:  # a rectangle c +- a +- b: the plane primitive's corners (+-1, +-1) moved there
            bpy.ops.mesh.primitive_plane_add(size=2.0)
            obj = bpy.context.object
            c = verts.mean(0)
            a = 0.5 * (verts[1] - verts[0])
            b = 0.5 * (verts[3] - verts[0])
            for v in obj.data.vertices:
                sx, sy = math.copysign(1.0, v.co.x), math.copysign(1.0, v.co.y)
                v.co = tuple(c + sx * a + sy * b)
            obj.data.update()
        obj.name = name
        obj.data.materials.append(_material(bpy, name, COLOURS[name]))
        objects[name] = obj
    return objects


def build(bpy, testdata, width=96, height=64, count=20000):
    """(HoldoutScene, {name: mesh object}, splat object) in the current (empty) scene."""
    from addon.blender.data.files import import_file

    hs = guitar_scene(testdata, width, height)
    splats = import_file(bpy.context, testdata / "guitar.ply", max_count=count)
    add_camera_for(bpy, hs.camera)
    objects = add_meshes(bpy, hs.meshes)
    setup_render(bpy, width, height)
    return hs, objects, splats
