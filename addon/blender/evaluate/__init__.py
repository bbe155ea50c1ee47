"""Evaluation: a depsgraph in, a list of core RenderItems out (items.collect_items).

Reads Blender (look, effect stack, keyframes, sequence frame) and hands the maths to core.
The viewport and the render engine get their items here and nowhere else.
"""
