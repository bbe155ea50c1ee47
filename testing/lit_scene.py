"""The scene of the lighting tests and bench (issue 43): a floor of flat white splats and the
same floor as a mesh plane with a white Diffuse BSDF, a light, a camera and a grey World, so
Splatline's engine and Cycles render the same thing."""
from __future__ import annotations

import math

import numpy as np

from addon.core.sh import C0
from addon.core.splats import AXES_RFU, SplatSet

FLOOR = 2.4     # metres across
SPACING = 0.02


def white_floor(spacing: float = SPACING, size: float = FLOOR, z: float = 0.0) -> SplatSet:
    """Flat, opaque, white splats tiling z = 0: their colour is 1 (DC), their normal +z."""
    ticks = np.arange(-size / 2, size / 2 + 1e-9, spacing)
    xs, ys = np.meshgrid(ticks, ticks)
    s = SplatSet.allocate(xs.size, 0, AXES_RFU)
    s.positions[:] = np.c_[xs.ravel(), ys.ravel(), np.full(xs.size, z)]
    s.scales[:] = (spacing, spacing, spacing * 0.01)
    s.rotations[:] = (1.0, 0.0, 0.0, 0.0)
    s.opacities[:] = 1.0
    s.sh_dc[:] = 0.5 / C0
    return s


LIGHTS = {  # (type, energy, extra settings): all at (0.3, 0.2, 1.5), shining down
    "SUN": ("SUN", 2.0, {"angle": 0.0}),
    "POINT": ("POINT", 200.0, {"shadow_soft_size": 0.0}),
    "SPOT": ("SPOT", 300.0, {"shadow_soft_size": 0.0, "spot_size": math.radians(70), "spot_blend": 0.4}),
    "AREA": ("AREA", 300.0, {"size": 0.1}),
}


def add_light(bpy, kind: str, location=(0.3, 0.2, 1.5), rotation=(0.0, 0.0, 0.0)):
    light_type, energy, extra = LIGHTS[kind]
    data = bpy.data.lights.new(kind.title(), light_type)
    data.energy = energy
    for name, value in extra.items():
        setattr(data, name, value)
    obj = bpy.data.objects.new(kind.title(), data)
    bpy.context.scene.collection.objects.link(obj)
    obj.location, obj.rotation_euler = location, rotation
    return obj


def add_mesh_floor(bpy, size: float = FLOOR):
    bpy.ops.mesh.primitive_plane_add(size=size)
    plane = bpy.context.view_layer.objects.active
    mat = bpy.data.materials.new("White")
    mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.clear()
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(diffuse.outputs[0], out.inputs["Surface"])
    plane.data.materials.append(mat)
    return plane


def grey_world(bpy, scene, value: float = 0.05):
    from addon.blender.compat import world_node_tree

    world = scene.world = bpy.data.worlds.new("Grey")
    tree = world_node_tree(world)
    background = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBackground")
    background.inputs["Color"].default_value = (value, value, value, 1.0)
    background.inputs["Strength"].default_value = 1.0
    world.color = (value, value, value)
    return world


def top_camera(bpy, scale: float = 2.0):
    """An orthographic camera looking straight down at the floor's middle."""
    data = bpy.data.cameras.new("Top")
    data.type, data.ortho_scale = "ORTHO", scale
    obj = bpy.data.objects.new("Top", data)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = (0.0, 0.0, 4.0)
    bpy.context.scene.camera = obj
    return obj
