"""Splats' shadows on meshes in Splatline's frame (Blender 5.3+, Mesh Engine EEVEE or Cycles).

Splatline's engine draws the splats; the meshes come from Blender's engine rendering the
mesh scene (mesh_layer.py), which holds no splat object, so no splat shadowed a mesh.
Blender 5.3's EEVEE and Cycles draw native splats and let them cast shadows (measured:
bench/native_lights_bench.py), and they keep an object hidden from the camera
(Object > Visibility > Camera off) out of the frame while it still casts its shadow. So the
mesh scene gets one **shadow caster** per splat object of the Splatline scene:

- an object of its own whose Geometry Nodes modifier shows the splat object's evaluated
  geometry (Object Info, relative space: placed where the splat object is, at every frame);
  with a 5.3 handoff (evaluated_geometry.py) that is the splats after effects and look;
- seen by no camera, reflection, refraction or volume ray; casting shadows as the splat
  object's own Visibility > Shadow says (off there: no shadow from it).

Not for Workbench (it draws objects hidden from the camera) nor before 5.3 (no native
splats: a point cloud would shadow as points). The casters are made and removed by
mesh_layer.sync, never during a render; each write is skipped where the value is already
right.
"""
from __future__ import annotations

import bpy

from ..data import native
from ..data import evaluated_geometry
from ..data.evaluated_geometry import object_info_group
from ..data.pointcloud import CASTER_MARK
from ..data.sources import is_splat_object

SUFFIX = "splat shadows"          # the mesh scene's collection of casters
MODIFIER = "Splatline shadow"
HIDDEN_RAYS = ("visible_camera", "visible_diffuse", "visible_glossy", "visible_transmission",
               "visible_volume_scatter")


def engines_cast(scene) -> bool:
    """Whether this Blender and the Mesh Engine draw splats' shadows on meshes."""
    return native.has_native_splats() and scene.splatline.render.mesh_engine in ("EEVEE", "CYCLES")


def sources(scene, render_objects) -> list:
    """The splat objects that cast shadows on the mesh layer (none where engines_cast is not)."""
    if not engines_cast(scene):
        return []
    return sorted((o for o in render_objects if is_splat_object(o)), key=lambda o: o.name_full)


def source_of(caster):
    """The splat object a caster shows, or None."""
    modifier = caster.modifiers.get(MODIFIER)
    group = getattr(modifier, "node_group", None)
    info = None if group is None else group.nodes.get("Object Info")
    return None if info is None else info.inputs["Object"].default_value


def sync(collection, wanted, set_value, wrote) -> None:
    """Make `collection` (the mesh scene's, None where it has none) hold one caster per
    splat object of `wanted`; set_value(owner, name, value) writes only a change, wrote()
    records a write."""
    have = {} if collection is None else {source_of(c): c for c in collection.objects if CASTER_MARK in c.keys()}
    for source in wanted:
        caster = have.pop(source, None)
        if caster is None:
            wrote()
            caster = _make(source)
            collection.objects.link(caster)
        for name in HIDDEN_RAYS:
            set_value(caster, name, False)
        set_value(caster, "visible_shadow", bool(source.visible_shadow))
    for caster in have.values():
        wrote()
        remove(caster)


def _make(source):
    """A caster of source: its own empty splat PointCloud, the modifier and its node group.
    Atomic: on failure nothing new is left behind."""
    made = []
    try:
        name = f"{source.name} (Splatline shadow)"
        data = bpy.data.pointclouds.new(name)
        made.append((bpy.data.pointclouds, data))
        native.mark_as_splats(data)
        caster = bpy.data.objects.new(name, data)
        made.append((bpy.data.objects, caster))
        caster[CASTER_MARK] = True
        group = object_info_group(name, source, "RELATIVE")  # placed where source is
        made.append((bpy.data.node_groups, group))
        caster.modifiers.new(MODIFIER, "NODES").node_group = group
        return caster
    except BaseException:
        for blocks, block in reversed(made):
            blocks.remove(block)
        raise


def remove(caster) -> None:
    """A caster, its node group and its data."""
    group = getattr(caster.modifiers.get(MODIFIER), "node_group", None)
    evaluated_geometry.drop_object(caster)
    evaluated_geometry.drop_unused(group)
