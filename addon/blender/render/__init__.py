"""The Splatline RenderEngine (F12 and the rendered viewport) and what it needs: the Blender
camera as a core Camera, the film (region, colour, depth), the renderer paths (moderngl,
Blender's gpu module, reference) and stopping a render on Ctrl+C."""
