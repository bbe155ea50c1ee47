# Preview: half resolution, 16-bit sort keys, quads capped at 3 sigma, PNG; fast look-dev turnarounds.
import bpy
scene = bpy.context.scene
scene.render.resolution_percentage = 50
image = scene.render.image_settings
if hasattr(image, 'media_type'):  # Blender 5.0+ picks it before file_format; 4.5 has none
    image.media_type = 'IMAGE'
image.file_format = 'PNG'
image.color_mode = 'RGBA'
image.color_depth = '8'
settings = scene.splatline.render
settings.key_bits = '16'
settings.capped_extent = True
settings.antialiased = False
