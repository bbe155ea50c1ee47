"""Blender API differences between the versions Splatline supports (4.5 LTS and 5.x).

Feature detection on RNA, never version numbers: a property's presence says what the
running Blender accepts. Needs no bpy import, so it also works on stand-in objects.
"""
from __future__ import annotations

# Blender 5.0 split file_format by image_settings.media_type; these are the formats a
# media type other than IMAGE has to be chosen for first (before 5.0: no media_type).
_MEDIA_TYPES = {"OPEN_EXR_MULTILAYER": "MULTI_LAYER_IMAGE", "FFMPEG": "VIDEO"}


def has_media_type(image) -> bool:
    """Whether these ImageFormatSettings have Blender 5.0's media_type."""
    return "media_type" in image.bl_rna.properties


def set_file_format(image, file_format: str) -> None:
    """Set image.file_format on any supported Blender.

    5.0 only accepts OPEN_EXR_MULTILAYER under MULTI_LAYER_IMAGE and FFMPEG under VIDEO,
    so its media_type goes first; 4.5 has none and takes every format directly."""
    if has_media_type(image):
        image.media_type = _MEDIA_TYPES.get(file_format, "IMAGE")
    image.file_format = file_format


def media_type(image) -> str:
    """image.media_type where it exists; before 5.0, the one its file_format implies."""
    if has_media_type(image):
        return image.media_type
    return _MEDIA_TYPES.get(image.file_format, "IMAGE")


def _use_nodes_is_live(world) -> bool:
    """4.5's World.use_nodes chooses tree or world.color; 5.0 deprecates it (always on)."""
    prop = world.bl_rna.properties.get("use_nodes")
    return prop is not None and not getattr(prop, "is_deprecated", False)


def world_uses_nodes(world) -> bool:
    """Whether Cycles/EEVEE render this world's node tree (else its flat world.color)."""
    if world.node_tree is None:
        return False
    return world.use_nodes if _use_nodes_is_live(world) else True


def world_node_tree(world):
    """The world's node tree, made (Background -> World Output) where 4.5 has none yet."""
    if _use_nodes_is_live(world) and not world.use_nodes:
        world.use_nodes = True  # 4.5: bpy.data.worlds.new() has no tree until this
    return world.node_tree


def new_compositor(scene, name: str):
    """(tree, socket): a fresh compositor for `scene` and the input its result must feed.

    5.0: a CompositorNodeTree group on scene.compositing_node_group, out through its Group
    Output's Image socket. 4.5: scene.use_nodes gives the scene its own (embedded) tree,
    out through a Composite node."""
    import bpy

    if "compositing_node_group" in scene.bl_rna.properties:
        tree = bpy.data.node_groups.new(name, "CompositorNodeTree")
        tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
        scene.compositing_node_group = tree
        return tree, tree.nodes.new("NodeGroupOutput").inputs[0]
    scene.use_nodes = True
    tree = scene.node_tree
    tree.nodes.clear()  # 4.5 starts it with Render Layers -> Composite
    return tree, tree.nodes.new("CompositorNodeComposite").inputs["Image"]


def compositor_tree(scene):
    """The scene's compositor node tree (None if it has none), on 4.5 or 5.x."""
    if "compositing_node_group" in scene.bl_rna.properties:
        return scene.compositing_node_group
    return scene.node_tree


def active_compositor(scene):
    """The compositor tree that composites this scene's frames, or None: 5.x's
    compositing_node_group; 4.5's node_tree only while scene.use_nodes is on (a tree that
    was switched off stays on the scene, unused). Render > Post Processing > Compositing
    (render.use_compositing) is the caller's to check."""
    if "compositing_node_group" in scene.bl_rna.properties:
        return scene.compositing_node_group
    return scene.node_tree if scene.use_nodes else None
