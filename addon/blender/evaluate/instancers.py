"""Which objects instance splat objects: a collection instance of a collection with splats,
vertex/face instancing of a splat child, a Geometry Nodes modifier that reads a splat object
or collection (a node's value or the modifier's input). Read from the objects' settings
alone, never from the evaluated instances: walking `depsgraph.object_instances` costs
~2.5-10 us an instance in Python (100k mesh instances: 0.25-1 s), so the evaluator walks
them only where this says splats may be among them, and the mesh layer leaves such objects
out (its engine would draw their splats again).
"""
from __future__ import annotations

import bpy

from ..data.sources import is_splat_object

MAX_DEPTH = 32  # nested instancing deeper than this is taken to hold splats


def holds_splats(collection, depth=0) -> bool:
    if depth > MAX_DEPTH:
        return True
    if any(is_splat_object(o) or instances_splats(o, depth + 1) for o in collection.all_objects):
        return True
    return False


def instances_splats(obj, depth=0) -> bool:
    """obj (an original object) may instance splat objects."""
    if depth > MAX_DEPTH:
        return True
    kind = obj.instance_type
    if kind == "COLLECTION" and obj.instance_collection is not None:
        if holds_splats(obj.instance_collection, depth):
            return True
    elif kind in ("VERTS", "FACES") and any(is_splat_object(c) or instances_splats(c, depth + 1)
                                            for c in obj.children):
        return True
    return _nodes_instance_splats(obj, depth)


def may_instance_splats(depsgraph) -> bool:
    """Some object the depsgraph draws may instance splats (instances_splats)."""
    return any(instances_splats(obj.original) for obj in depsgraph.objects)


def _nodes_instance_splats(obj, depth=0) -> bool:
    """A Geometry Nodes modifier of obj reads a splat object or a collection with splats
    (Object Info, Collection Info, or the modifier's inputs): its output may instance them.
    Splatline's engine draws those instances; the mesh layer must not draw them again."""
    for modifier in obj.modifiers:
        if modifier.type != "NODES" or modifier.node_group is None:
            continue
        if any(_is_splat_source(i, depth) for i in _input_ids(modifier) + _node_ids(modifier.node_group)):
            return True
    return False


def _input_ids(modifier) -> list:
    """The objects and collections given to the modifier's inputs: ID properties up to
    5.1; from 5.2 (where the modifier has none) modifier.properties.inputs.<identifier>.value."""
    interface = getattr(modifier, "properties", None)
    if interface is not None:
        inputs = interface.inputs
        values = [getattr(getattr(inputs, k), "value", None) for k in inputs.bl_rna.properties.keys()
                  if k not in ("rna_type", "name")]
    else:
        values = [modifier[k] for k in modifier.keys()]
    return [v for v in values if isinstance(v, (bpy.types.Object, bpy.types.Collection))]


def _node_ids(tree, seen=None) -> list:
    """The objects and collections that the nodes of a tree and of its groups name."""
    seen = set() if seen is None else seen
    if tree.name_full in seen:
        return []
    seen.add(tree.name_full)
    out = []
    for node in tree.nodes:
        if getattr(node, "node_tree", None) is not None:
            out += _node_ids(node.node_tree, seen)
        for socket in node.inputs:
            value = getattr(socket, "default_value", None)
            if isinstance(value, (bpy.types.Object, bpy.types.Collection)):
                out.append(value)
    return out


def _is_splat_source(block, depth) -> bool:
    if isinstance(block, bpy.types.Collection):
        return holds_splats(block, depth + 1)
    return isinstance(block, bpy.types.Object) and (is_splat_object(block) or instances_splats(block, depth + 1))
