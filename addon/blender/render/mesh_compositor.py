"""The mesh layer's compositor (mesh_layer.py): the Splatline scene's Render Layers nodes
each go through an Alpha Over whose background is the mesh scene's Render Layers node.

Every write is reported through the caller's `wrote()` and skipped where the tree already
is right, so a sync that finds nothing to do changes nothing (no depsgraph update loop).
"""
from __future__ import annotations

import bpy

from .. import compat

OWNED = "splatline_mesh_compositor"   # on a compositor tree Splatline made
MESH_NODE = "Splatline Meshes"        # the Render Layers node of the mesh scene
MESH_OVER = "Splatline Over Meshes"   # prefix of the Alpha Over nodes


def _own_layer_nodes(tree, scene):
    return [n for n in tree.nodes if n.bl_idname == "CompositorNodeRLayers"
            and n.name != MESH_NODE and n.scene in (None, scene)]


def _over_inputs(node):
    """(background, foreground) inputs of an Alpha Over node: named in 5.x, both 'Image'
    in 4.5 (inputs 1 and 2)."""
    names = [s.name for s in node.inputs]
    if "Background" in names:
        return node.inputs["Background"], node.inputs["Foreground"]
    return node.inputs[1], node.inputs[2]


def _ensure_tree(scene, wrote):
    tree = compat.active_compositor(scene)
    if tree is not None:
        return tree
    wrote()
    if "compositing_node_group" in scene.bl_rna.properties:
        tree, output = compat.new_compositor(scene, f"{scene.name} Splatline meshes")
    else:
        tree, output = compat.new_compositor(scene, "")
    tree[OWNED] = True
    layers = tree.nodes.new("CompositorNodeRLayers")
    layers.scene = scene
    layers.location = (-300, 0)
    output.node.location = (300, 0)
    tree.links.new(layers.outputs["Image"], output)
    return tree


def attach(scene, companion, wrote) -> None:
    """Route each of the scene's own Render Layers nodes through an Alpha Over over the
    mesh scene's layer (a compositor made where the scene has none)."""
    tree = _ensure_tree(scene, wrote)
    meshes = tree.nodes.get(MESH_NODE)
    if meshes is None or meshes.bl_idname != "CompositorNodeRLayers":
        wrote()
        meshes = tree.nodes.new("CompositorNodeRLayers")
        meshes.name = meshes.label = MESH_NODE
        meshes.location = (-300, -300)
    if meshes.scene != companion:
        wrote()
        meshes.scene = companion
    if meshes.layer != companion.view_layers[0].name:
        wrote()
        meshes.layer = companion.view_layers[0].name
    for layers in _own_layer_nodes(tree, scene):
        image = layers.outputs["Image"]
        name = f"{MESH_OVER} {layers.name}"
        over = tree.nodes.get(name)
        if over is None:
            wrote()
            over = tree.nodes.new("CompositorNodeAlphaOver")
            over.name = over.label = name
            over.location = (layers.location.x + 200, layers.location.y)
        background, foreground = _over_inputs(over)
        targets = [link.to_socket for link in image.links if link.to_node != over]
        for link in list(image.links):
            if link.to_node != over:
                wrote()
                tree.links.remove(link)
        for socket in targets:
            tree.links.new(over.outputs[0], socket)
        if not any(link.from_socket == image for link in foreground.links):
            wrote()
            tree.links.new(image, foreground)
        if not any(link.from_socket == meshes.outputs["Image"] for link in background.links):
            wrote()
            tree.links.new(meshes.outputs["Image"], background)


def detach(scene, wrote) -> None:
    """Undo attach: remove a compositor Splatline made, or take its nodes out of the user's,
    relinking what they joined."""
    tree = compat.active_compositor(scene)
    if tree is None:
        return
    if tree.get(OWNED):
        wrote()
        if "compositing_node_group" in scene.bl_rna.properties:
            scene.compositing_node_group = None
            if tree.users == 0:
                bpy.data.node_groups.remove(tree)
        else:  # 4.5: the tree is the scene's own; leave it empty, switched off, unmarked
            tree.nodes.clear()
            del tree[OWNED]
            scene.use_nodes = False
        return
    for over in [n for n in tree.nodes if n.name.startswith(MESH_OVER)]:
        wrote()
        _background, foreground = _over_inputs(over)
        sources = [link.from_socket for link in foreground.links]
        targets = [link.to_socket for link in over.outputs[0].links]
        tree.nodes.remove(over)
        for source in sources:
            for socket in targets:
                tree.links.new(source, socket)
    meshes = tree.nodes.get(MESH_NODE)
    if meshes is not None:
        wrote()
        tree.nodes.remove(meshes)


def holds(scene, companion) -> bool:
    """Whether the scene's final frame holds the mesh scene companion's layer: compositing
    on, its tree with companion's Render Layers node under an Alpha Over."""
    tree = compat.active_compositor(scene)
    if companion is None or tree is None or not scene.render.use_compositing:
        return False
    meshes = tree.nodes.get(MESH_NODE)
    return (meshes is not None and meshes.scene == companion and not meshes.mute
            and any(n.name.startswith(MESH_OVER) and not n.mute for n in tree.nodes))


def why_not(scene, companion) -> str:
    """One line for the render's warning: why the mesh layer is not in the frame."""
    if not scene.render.use_compositing:
        return "Output > Post Processing > Compositing is off"
    if companion is None:
        return "the scene has no mesh scene yet (it is made after an edit or on file load)"
    return ("the compositor has no Render Layers node of the mesh scene under an Alpha Over "
            f"(set Meshes to Drawn again, or add {MESH_NODE!r} yourself)")
