# PNG sequence: 16-bit RGBA.
import bpy
scene = bpy.context.scene
image = scene.render.image_settings
if hasattr(image, 'media_type'):  # Blender 5.0+ picks it before file_format; 4.5 has none
    image.media_type = 'IMAGE'
image.file_format = 'PNG'
image.color_mode = 'RGBA'
image.color_depth = '16'
image.compression = 15
