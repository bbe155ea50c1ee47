# EXR sequence: full float RGBA, single layer.
import bpy
scene = bpy.context.scene
image = scene.render.image_settings
if hasattr(image, 'media_type'):  # Blender 5.0+ picks it before file_format; 4.5 has none
    image.media_type = 'IMAGE'
image.file_format = 'OPEN_EXR'
image.color_mode = 'RGBA'
image.color_depth = '32'
image.exr_codec = 'ZIP'
