"""The geometry Blender's own engines draw for a splat object whose splats Splatline changes.

On a Blender with native splats (native.py), Workbench, EEVEE and Cycles render an object's
evaluated geometry. Splatline's look, effects, crop, morphs and sequences are Python, and
Python cannot be a modifier, so the evaluated splats reach Blender this way:
- a companion object, linked into no scene, holds them in its own PointCloud (set to the
  splat type), written by evaluate/native_handoff.py whenever they change;
- a Geometry Nodes modifier, last on the splat object, puts the companion's geometry in
  place of the object's own (Object Info, "Original" space: the companion's data is already
  in the object's space).

Measured on bpy 5.3.0: the companion is not listed in `depsgraph.objects` (it renders only
through the modifier); Object Info hands over every attribute and the GAUSSIAN_SPLAT type,
also for an empty PointCloud; the pair survives save and reload.

Splatline itself always reads the object's own data (`own_data`), never the modifier's
output, so nothing is evaluated twice. With a handoff, modifiers before it are not seen by
Splatline: it reads the object's PointCloud as stored.

The node group is one per object: Object Info's object is a node value, since a Geometry
Nodes modifier's group inputs take no ID values from Python on 5.x.
"""
from __future__ import annotations

import bpy

from . import native
from .pointcloud import COMPANION_MARK, overwrite_pointcloud

MODIFIER = "Splatline"
GROUP_MARK = "splatline_evaluated"        # on the node group


def handoff_modifier(obj):
    """The handoff modifier of an object (original or evaluated), or None."""
    for modifier in reversed(obj.modifiers):
        group = getattr(modifier, "node_group", None)
        if modifier.type == "NODES" and group is not None and group.get(GROUP_MARK):
            return modifier
    return None


def companion(obj):
    """The companion object holding obj's evaluated splats, or None without a handoff."""
    modifier = handoff_modifier(obj)
    if modifier is None:
        return None
    for node in modifier.node_group.nodes:
        if node.bl_idname == "GeometryNodeObjectInfo":
            return node.inputs["Object"].default_value
    return None


def claim(obj):
    """obj's own companion, or None where it has none of its own. A duplicated object
    (Shift+D) carries a copy of the modifier that still shows the original's companion: its
    modifier goes, and install() gives it its own. A renamed object keeps its companion."""
    other = companion(obj)
    if other is None:
        return None
    owner = other.get(COMPANION_MARK)
    if owner == obj.name:
        return other
    first = bpy.data.objects.get(owner) if isinstance(owner, str) else None
    if first is not None and first is not obj and companion(first) is other:
        obj.modifiers.remove(handoff_modifier(obj))
        return None
    other[COMPANION_MARK] = obj.name
    return other


def is_companion(obj) -> bool:
    return obj is not None and COMPANION_MARK in obj.keys()


def own_data(obj_eval, depsgraph):
    """The PointCloud holding the object's own splats at the depsgraph's state: the evaluated
    data, or with a handoff, the object's data before its modifiers."""
    if handoff_modifier(obj_eval) is None:
        return obj_eval.data
    return obj_eval.original.data.evaluated_get(depsgraph)


def install(obj):
    """Give obj a companion and the modifier that shows it; returns the companion.
    Atomic: on failure nothing new is left behind."""
    found = claim(obj)
    if found is not None:
        return found
    made = []
    try:
        data = bpy.data.pointclouds.new(f"{obj.name} (evaluated)")
        made.append((bpy.data.pointclouds, data))
        native.mark_as_splats(data)
        other = bpy.data.objects.new(f"{obj.name} (evaluated)", data)
        made.append((bpy.data.objects, other))
        other[COMPANION_MARK] = obj.name
        group = _node_group(f"Splatline evaluated: {obj.name}", other)
        made.append((bpy.data.node_groups, group))
        modifier = obj.modifiers.new(MODIFIER, "NODES")
        modifier.node_group = group
        modifier.show_in_editmode = False
        return other
    except BaseException:
        for collection, block in reversed(made):
            collection.remove(block)
        raise


def _node_group(name, source):
    group = object_info_group(name, source, "ORIGINAL")
    group[GROUP_MARK] = True
    return group


def object_info_group(name, source, space: str):
    """A Geometry Nodes group whose output is source's evaluated geometry (Object Info in
    `space`: ORIGINAL keeps its own space, RELATIVE places it where source is)."""
    group = bpy.data.node_groups.new(name, "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    info = group.nodes.new("GeometryNodeObjectInfo")
    info.name = "Object Info"
    info.transform_space = space
    info.inputs["Object"].default_value = source
    out = group.nodes.new("NodeGroupOutput")
    out.location = (300, 0)
    group.links.new(info.outputs["Geometry"], out.inputs["Geometry"])
    return group


def remove(obj) -> None:
    """Take obj's handoff away: modifier, node group, companion and its data."""
    modifier = handoff_modifier(obj)
    if modifier is None:
        return
    other, group = companion(obj), modifier.node_group
    obj.modifiers.remove(modifier)
    drop_unused(group)
    if other is not None:
        drop_object(other)


def drop_object(obj) -> None:
    """Remove obj, and its point cloud once nothing else uses it."""
    data = obj.data
    bpy.data.objects.remove(obj)
    drop_unused(data)


def drop_unused(block) -> None:
    """Remove a node group or point cloud that nothing uses any more (None: nothing)."""
    if block is None or block.users:
        return
    blocks = bpy.data.node_groups if isinstance(block, bpy.types.NodeTree) else bpy.data.pointclouds
    blocks.remove(block)


def _same(a, b) -> bool:
    """The same array, or a view of exactly its memory (with_sh_degree's full-degree view).
    Safe by address because `held` keeps the old arrays alive: their memory is not reused."""
    return a is b or (a.__array_interface__ == b.__array_interface__)


# What a companion holds, by SplatSet field: opacities and sh_dc share one attribute.
_GROUPS = {"positions": ("positions",), "scales": ("scales",), "rotations": ("rotations",),
           "base": ("opacities", "sh_dc"), "sh_rest": ("sh_rest",)}


def write(other, splats, held=None) -> dict:
    """The companion's PointCloud now holds `splats` (object space, look folded in).

    `held`: what the last write returned for this companion, or None. Arrays that are the
    very ones written last time (the evaluator's caches are read-only, and an effect makes
    new arrays for what it changes) are not written again: a fade rewrites one attribute of
    the 19 a degree-3 capture has. Returns what to pass next time."""
    arrays = {group: tuple(getattr(splats, f) for f in fields) for group, fields in _GROUPS.items()}
    unchanged = frozenset()
    if held is not None and held.get("count") == splats.count:
        unchanged = frozenset(g for g, a in arrays.items()
                              if len(a) == len(held.get(g, ())) and all(map(_same, a, held[g])))
    overwrite_pointcloud(other.data, splats, unchanged)
    return {"count": splats.count, **arrays}
