"""A real capture relit (issue 43): guitar.ply imported with its axes on the object, Look >
Lighting 1, a spot light sweeping across it (keyed), a cube between the light and the guitar
casting its shadow, a dim World and a camera in front. Built with real bpy; the tests and
the note's frame render it through the command line."""
from __future__ import annotations

import numpy as np


def build(bpy, testdata, frames: int = 4):
    from addon.blender.data.files import import_file
    from testing.engine_scene import add_camera
    from testing.lit_scene import grey_world

    obj = import_file(bpy.context, str(testdata / "guitar.ply"))
    assert obj.rotation_euler[:] != (0.0, 0.0, 0.0)   # the file's axes sit on the object
    obj.splatline.look.lighting = 1.0
    bpy.context.view_layer.update()
    corners = np.array([obj.matrix_world @ v for v in _box(obj)])
    centre, size = corners.mean(0), float(np.linalg.norm(np.ptp(corners, axis=0)))
    add_camera(bpy, location=tuple(centre + (0.0, -1.6 * size, 0.2 * size)), target=tuple(centre))
    data = bpy.data.lights.new("Torch", "SPOT")
    data.energy, data.spot_size, data.spot_blend, data.shadow_soft_size = 1500.0, 0.6, 0.3, 0.0
    spot = bpy.data.objects.new("Torch", data)
    bpy.context.scene.collection.objects.link(spot)
    from mathutils import Vector

    for f in range(1, frames + 1):  # sweeps from left to right in front of the guitar, aimed at it
        x = centre[0] + size * (-0.5 + 1.0 * (f - 1) / max(frames - 1, 1))
        spot.location = (x, centre[1] - 0.8 * size, centre[2] + 0.3 * size)
        spot.rotation_euler = Vector(centre - np.array(spot.location)).to_track_quat("-Z", "Y").to_euler()
        spot.keyframe_insert("location", frame=f)
        spot.keyframe_insert("rotation_euler", frame=f)
    # a cube a third of the way from the sweep's middle to the guitar: its shadow crosses it
    middle = centre + np.array([0.0, -0.8 * size, 0.3 * size])
    bpy.ops.mesh.primitive_cube_add(size=0.08 * size, location=tuple(middle + (centre - middle) / 3))
    scene = bpy.context.scene
    grey_world(bpy, scene, 0.05)
    scene.frame_start, scene.frame_end = 1, frames
    scene.render.resolution_x, scene.render.resolution_y = 160, 120
    return obj, spot


def _box(obj):
    from mathutils import Vector

    return [Vector(c) for c in obj.bound_box]
