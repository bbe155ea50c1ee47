# H.264 in an MP4 container, high quality, for review and delivery.
import bpy
scene = bpy.context.scene
image = scene.render.image_settings
if hasattr(image, 'media_type'):  # Blender 5.0+ picks it before file_format; 4.5 has none
    image.media_type = 'VIDEO'
image.file_format = 'FFMPEG'
image.color_mode = 'RGB'
ffmpeg = scene.render.ffmpeg
ffmpeg.format = 'MPEG4'
ffmpeg.codec = 'H264'
ffmpeg.constant_rate_factor = 'HIGH'
ffmpeg.ffmpeg_preset = 'GOOD'
ffmpeg.audio_codec = 'NONE'
