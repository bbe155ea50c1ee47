"""Instances of splat objects built with bpy, as a user makes them: a collection instance,
Geometry Nodes' Instance on Points, and the real copies they stand for (tests, benches)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np


def in_collection(bpy, obj, name="Splats"):
    """obj moved into a new collection of its own under the scene's (to be instanced)."""
    collection = bpy.data.collections.new(name)
    bpy.context.scene.collection.children.link(collection)
    for owner in list(obj.users_collection):
        owner.objects.unlink(obj)
    collection.objects.link(obj)
    return collection


def collection_instance(bpy, collection, location, name="Instance"):
    """An empty that instances `collection` at `location`."""
    empty = bpy.data.objects.new(name, None)
    empty.instance_type = "COLLECTION"
    empty.instance_collection = collection
    empty.location = location
    bpy.context.scene.collection.objects.link(empty)
    return empty


def instance_on_points(bpy, points, source, scale=1.0, name="Scatter", as_input=False):
    """A mesh of `points` (vertices only) whose Geometry Nodes modifier puts an instance
    of `source` on each: an Object Info node (As Instance) for an object, a Collection
    Info node for a collection; each instance scaled by `scale`. as_input: the object is
    the modifier's input, not the node's own value."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(map(float, p)) for p in points], [], [])
    host = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(host)
    tree = bpy.data.node_groups.new(name, "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    group_in, group_out = tree.nodes.new("NodeGroupInput"), tree.nodes.new("NodeGroupOutput")
    on_points = tree.nodes.new("GeometryNodeInstanceOnPoints")
    if isinstance(source, bpy.types.Collection):
        info = tree.nodes.new("GeometryNodeCollectionInfo")
        info.inputs["Collection"].default_value = source
    else:
        info = tree.nodes.new("GeometryNodeObjectInfo")
        info.inputs["Object"].default_value = source
        info.inputs["As Instance"].default_value = True
    on_points.inputs["Scale"].default_value = (scale, scale, scale)
    tree.links.new(group_in.outputs[0], on_points.inputs["Points"])
    tree.links.new(info.outputs["Geometry"] if "Geometry" in info.outputs else info.outputs[0],
                   on_points.inputs["Instance"])
    tree.links.new(on_points.outputs["Instances"], group_out.inputs[0])
    modifier = host.modifiers.new("Scatter", "NODES")
    modifier.node_group = tree
    if as_input:
        socket = tree.interface.new_socket("Source", in_out="INPUT", socket_type="NodeSocketObject")
        tree.links.new(group_in.outputs[socket.identifier], info.inputs["Object"])
        info.inputs["Object"].default_value = None
        set_input(modifier, socket.identifier, source)
    return host


def set_input(modifier, identifier, value):
    """A Geometry Nodes modifier's input: an ID property up to 5.1, properties.inputs from 5.2."""
    interface = getattr(modifier, "properties", None)
    if interface is not None:
        getattr(interface.inputs, identifier).value = value
    else:
        modifier[identifier] = value


def instance_matrices(bpy, name_full) -> list:
    """World matrices of the instances of object `name_full` the depsgraph draws."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    return [np.array(i.matrix_world, np.float64) for i in depsgraph.object_instances
            if i.is_instance and i.object.original.name_full == name_full]


def real_copies(bpy, source, matrices, name="Copy"):
    """Linked duplicates of `source` (its data and settings) at `matrices`."""
    from mathutils import Matrix

    copies = []
    for k, m in enumerate(matrices):
        copy = source.copy()
        copy.name = f"{name}{k}"
        copy.matrix_world = Matrix(np.asarray(m).tolist())
        bpy.context.scene.collection.objects.link(copy)
        copies.append(copy)
    return copies


def merged_item(items):
    """One RenderItem holding every item's splats in world space (the items move and scale
    their splats uniformly, so the higher SH bands need no turning): what a single merged
    object of all the instances is."""
    from addon.core.edit import merge
    from addon.core.scene import RenderItem

    sets = []
    for item in items:
        linear = item.world[:3, :3]
        s = np.linalg.det(linear) ** (1.0 / 3.0)
        if not np.allclose(linear, s * np.eye(3), atol=1e-9):
            raise ValueError("merged_item takes moved and uniformly scaled items only")
        sp = item.splats
        positions = (sp.positions.astype(np.float64) * s + item.world[:3, 3]).astype(np.float32)
        sets.append(replace(sp, positions=positions, scales=(sp.scales * np.float32(s)).astype(np.float32)))
    return RenderItem(merge(sets))
