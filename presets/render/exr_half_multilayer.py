# EXR sequence: half-float RGBA + Z, multilayer (compositing-ready).
import bpy
scene = bpy.context.scene
image = scene.render.image_settings
if hasattr(image, 'media_type'):  # Blender 5.0+ picks it before file_format; 4.5 has none
    image.media_type = 'MULTI_LAYER_IMAGE'
image.file_format = 'OPEN_EXR_MULTILAYER'
image.color_mode = 'RGBA'
image.color_depth = '16'
image.exr_codec = 'ZIP'
for view_layer in scene.view_layers:
    view_layer.use_pass_z = True
