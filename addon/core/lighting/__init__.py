"""Blender's lights on splats (issue 43): the scene's lights as plain parameters, splat
normals, shading in Cycles' units, and shadows. Pure numpy."""
