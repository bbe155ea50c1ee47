# PNG sequence: 16-bit RGBA.
import bpy
scene = bpy.context.scene
image = scene.render.image_settings
image.media_type = 'IMAGE'
image.file_format = 'PNG'
image.color_mode = 'RGBA'
image.color_depth = '16'
image.compression = 15
