"""The world behind the splats: Blender's World read into one plain scene-linear colour
(core/colorspace.composite_over puts the film over it; the engine's view_draw clears to it).
Only the constant background Cycles and EEVEE would render is read, never evaluated."""
from __future__ import annotations

from ..compat import world_uses_nodes


def world_background(world) -> tuple[float, float, float]:
    """The scene-linear colour the splats go over when Film > Transparent is off.

    Pass the EVALUATED world (`depsgraph.scene_eval.world`): node socket values and
    world.color may be keyframed or driven, and only the evaluated copy holds their
    value at the frame being rendered (the original keeps whatever was last written).

    `world.color` is only the world's viewport display colour; Cycles and EEVEE render
    the world's node tree where it uses nodes (`compat.world_uses_nodes`: 4.5's
    World.use_nodes; in 5.0 every world has a tree and use_nodes is deprecated). So:
    - no world: black, as Blender's engines give;
    - the active World Output's Surface fed (through reroutes) by an unmuted Background
      node whose Color and Strength inputs are both plain values: Color x Strength,
      the constant background Cycles/EEVEE would render;
    - anything else (no node tree, nothing or another shader at the output, or a
      Background whose Color or Strength comes from other nodes such as a sky or
      environment texture, which this engine does not evaluate): `world.color`, the
      one flat colour the user chose for that world (and what was used before).
    """
    if world is None:
        return (0.0, 0.0, 0.0)
    background = _background_node(world.node_tree) if world_uses_nodes(world) else None
    if background is not None:
        colour, strength = background.inputs["Color"], background.inputs["Strength"]
        if not (colour.is_linked or strength.is_linked):
            s = float(strength.default_value)
            return tuple(float(c) * s for c in colour.default_value[:3])
    return tuple(float(c) for c in world.color)


def _background_node(tree):
    """The Background node feeding the active World Output's Surface, or None."""
    if tree is None:
        return None
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if output is None:
        return None
    socket = output.inputs["Surface"]
    for _ in range(len(tree.nodes)):  # follow reroutes; bounded, so a cycle cannot hang
        links = [link for link in socket.links if link.is_valid and not link.is_muted]
        if not links:
            return None
        node = links[0].from_node
        if node.bl_idname == "NodeReroute":
            socket = node.inputs[0]
            continue
        return node if node.bl_idname == "ShaderNodeBackground" and not node.mute else None
    return None
