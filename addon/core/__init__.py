"""Pure-numpy core: formats, splat math, sorting, effects, the reference renderer.

Nothing here imports bpy or moderngl.
"""
