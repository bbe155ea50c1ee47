"""A movie (or stills) from an already rendered EXR sequence, through Blender's compositor.

The splats are rendered once, to scene-linear multilayer EXRs. A throw-away scene whose
compositor holds only an Image node playing that sequence then renders with the same
colour management as the source scene ("Standard" view: scene-linear back to display sRGB),
so the movie shows what the engine rendered without rendering a single splat again.

Why the compositor and not the Video Sequencer: a sequencer image strip reads a multilayer
EXR as black (measured with bpy 5.0.1), while the compositor's Image node reads its layers.
"""
from __future__ import annotations

import os

import bpy

from ..compat import compositor_tree, new_compositor, set_file_format
from ..data.presets import apply_render_preset

SCENE_NAME = "Splatline Video"


def encoding_scene(source, first_frame: str, count: int, layer: str | None = None):
    """A new scene with the size, rate and colour management of `source`, whose compositor
    outputs the image sequence starting at `first_frame` (count frames, numbered on from its
    number), or a movie file, on frames 1..count. `layer`: the EXR layer (default: the first)."""
    scene = bpy.data.scenes.new(SCENE_NAME)
    r, src = scene.render, source.render
    r.resolution_x, r.resolution_y = src.resolution_x, src.resolution_y
    r.resolution_percentage = src.resolution_percentage
    r.pixel_aspect_x, r.pixel_aspect_y = src.pixel_aspect_x, src.pixel_aspect_y
    r.fps, r.fps_base = src.fps, src.fps_base
    r.use_compositing, r.use_sequencer = True, False
    r.use_stamp_date, r.use_stamp_render_time = False, False
    r.dither_intensity = 0.0  # the same bytes from run to run, as the engine's frames
    _copy_colour_management(source, scene)
    scene.frame_start, scene.frame_end = 1, count
    try:
        _fill_tree(*new_compositor(scene, SCENE_NAME), first_frame, count, layer)
    except BaseException:
        remove_scene(scene)
        raise
    return scene


def _fill_tree(tree, output, first_frame: str, count: int, layer) -> None:
    image = bpy.data.images.load(first_frame, check_existing=False)
    if image.source == "FILE":  # a movie stays a movie
        image.source = "SEQUENCE"
    node = tree.nodes.new("CompositorNodeImage")
    node.image = image
    node.frame_start, node.frame_duration, node.frame_offset = 1, count, 0
    if layer is not None:
        node.layer = layer
    tree.links.new(node.outputs[0], output)  # Combined, or a movie's Image


def _copy_colour_management(source, scene) -> None:
    view, src = scene.view_settings, source.view_settings
    scene.display_settings.display_device = source.display_settings.display_device
    view.view_transform, view.look = src.view_transform, src.look
    view.exposure, view.gamma = src.exposure, src.gamma


def remove_scene(scene) -> None:
    """The scene, its node tree and its image, leaving bpy.data as it was."""
    tree = compositor_tree(scene)
    images = [n.image for n in tree.nodes if getattr(n, "image", None)] if tree else []
    standalone = tree is not None and not tree.is_embedded_data  # 4.5's goes with the scene
    bpy.data.scenes.remove(scene)
    if standalone:
        bpy.data.node_groups.remove(tree)
    for image in images:
        bpy.data.images.remove(image)


def encode(scene, path: str, preset: str = "h264_mp4") -> str:
    """Render the scene's whole range to one movie file with a render preset."""
    with bpy.context.temp_override(scene=scene):
        apply_render_preset(preset)
    scene.render.filepath = path
    scene.render.use_file_extension = False  # exactly `path`, no frame range appended
    bpy.ops.render.render(animation=True, scene=scene.name)
    return path


def still(scene, frame: int, path: str) -> str:
    """One frame of the scene as an 8-bit RGB PNG at `path`.

    Rendered as a one-frame animation: a still render of a scene that is not the window's
    does not advance the Image node's sequence frame (measured: it reads black)."""
    image = scene.render.image_settings
    set_file_format(image, "PNG")
    image.color_mode = "RGB"
    image.color_depth = "8"
    image.compression = 100
    start, end = scene.frame_start, scene.frame_end
    folder, name = os.path.split(os.path.abspath(path))
    scene.render.filepath = os.path.join(folder, f".{name}_####")
    scene.render.use_file_extension = False
    scene.frame_start = scene.frame_end = frame
    try:
        bpy.ops.render.render(animation=True, scene=scene.name)
    finally:
        scene.frame_start, scene.frame_end = start, end
    os.replace(scene.render.frame_path(frame=frame), path)
    return path
