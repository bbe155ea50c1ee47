# EXR sequence: half-float RGBA + Z, multilayer (compositing-ready).
import bpy
scene = bpy.context.scene
image = scene.render.image_settings
image.media_type = 'MULTI_LAYER_IMAGE'  # must come before file_format in Blender 5.0+
image.file_format = 'OPEN_EXR_MULTILAYER'
image.color_mode = 'RGBA'
image.color_depth = '16'
image.exr_codec = 'ZIP'
for view_layer in scene.view_layers:
    view_layer.use_pass_z = True
