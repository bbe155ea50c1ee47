# Apple ProRes 422 HQ in a QuickTime .mov: an edit-friendly intra-frame codec.
import bpy
scene = bpy.context.scene
image = scene.render.image_settings
if hasattr(image, 'media_type'):  # Blender 5.0+ picks it before file_format; 4.5 has none
    image.media_type = 'VIDEO'
image.file_format = 'FFMPEG'
image.color_mode = 'RGB'
ffmpeg = scene.render.ffmpeg
ffmpeg.format = 'QUICKTIME'
ffmpeg.codec = 'PRORES'
ffmpeg.ffmpeg_prores_profile = '422_HQ'
ffmpeg.audio_codec = 'NONE'
