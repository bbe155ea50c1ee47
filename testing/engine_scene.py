"""Small real scenes for the render-engine tests (real bpy, real splat objects)."""
from __future__ import annotations

import math

import numpy as np

from addon.core.sh import C0
from addon.core.splats import AXES_RFU, SplatSet

# The renderer the engine tests exercise: the offscreen GL one, as F12 and the farm use.
RENDERER = "OFFSCREEN"


def flat_splats(centres, colours, scale=0.5, opacity=1.0) -> SplatSet:
    """Isotropic degree-0 splats whose (clamped) SH colour is exactly `colours`."""
    centres = np.asarray(centres, np.float32).reshape(-1, 3)
    s = SplatSet.allocate(len(centres), 0, AXES_RFU)
    s.positions[:] = centres
    s.scales[:] = scale
    s.opacities[:] = opacity
    s.sh_dc[:] = (np.asarray(colours, np.float64).reshape(-1, 3) - 0.5) / C0
    return s


def add_splats(bpy, name, splats, location=(0.0, 0.0, 0.0)):
    from addon.blender.data.pointcloud import new_pointcloud_object

    obj = new_pointcloud_object(name, splats)
    obj.location = location
    return obj


def add_camera(bpy, location=(0.0, -8.0, 0.0), target=(0.0, 0.0, 0.0), lens=50.0):
    """A camera at location looking at target, with +z up, made the scene camera."""
    from mathutils import Vector

    scene = bpy.context.scene
    data = bpy.data.cameras.new("Camera")
    data.lens = lens
    obj = bpy.data.objects.new("Camera", data)
    scene.collection.objects.link(obj)
    obj.location = location
    obj.rotation_euler = (Vector(target) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    scene.camera = obj
    return obj


def setup_render(bpy, width, height, *, transparent=True, renderer=RENDERER):
    scene = bpy.context.scene
    scene.render.engine = "SPLATLINE"
    scene.splatline.render.renderer = renderer
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = transparent
    # Reproducible files: no render date/time in the metadata, no dither noise.
    scene.render.use_stamp_date = False
    scene.render.use_stamp_render_time = False
    scene.render.dither_intensity = 0.0
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    return scene


def set_output(scene, fmt, path, half=False):
    from addon.cli.render import configure_output

    configure_output(scene, fmt, str(path.parent), half)
    scene.render.filepath = str(path)


def orbit_keys(bpy, camera, radius, height, frames, target=(0.0, 0.0, 0.0)):
    """Keyframe the camera on a circle around target, one key per frame (a moving camera)."""
    from mathutils import Vector

    for i, frame in enumerate(frames):
        angle = -math.pi / 2 + 0.25 * i
        loc = Vector(target) + Vector((radius * math.cos(angle), radius * math.sin(angle), height))
        camera.location = loc
        camera.rotation_euler = (Vector(target) - loc).to_track_quat("-Z", "Y").to_euler()
        camera.keyframe_insert("location", frame=frame)
        camera.keyframe_insert("rotation_euler", frame=frame)


def guitar_scene(bpy, testdata, frames, width, height, count):
    """guitar.ply (the `count` most important splats) seen by a camera orbiting it."""
    from addon.blender.data.files import import_file
    from addon.blender.data.pointcloud import splats_from_pointcloud

    obj = import_file(bpy.context, testdata / "guitar.ply", max_count=count)
    local = splats_from_pointcloud(obj.data).positions.astype(np.float64)
    world = local @ np.array(obj.matrix_world)[:3, :3].T + np.array(obj.matrix_world)[:3, 3]
    lo, hi = np.percentile(world, [2, 98], axis=0)  # the capture, not its stray splats
    centre, size = (lo + hi) / 2, float(np.linalg.norm(hi - lo))
    camera = add_camera(bpy, location=tuple(centre + (0, -size, 0)), target=tuple(centre))
    orbit_keys(bpy, camera, radius=1.1 * size, height=0.1 * size, frames=frames, target=tuple(centre))
    scene = setup_render(bpy, width, height)
    scene.frame_start, scene.frame_end = frames[0], frames[-1]
    return scene, centre, size


def read_exr_parts(path):
    """{part name: (H, W, C) float32 top-down} for every part of a multi-part EXR.

    Blender 5.0 writes a multilayer EXR as one part per pass ("ViewLayer.Combined");
    4.5 writes one part of "ViewLayer.Combined.R"... channels: split those by pass."""
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    assert inp is not None, oiio.geterror()
    parts, index = {}, 0
    try:
        while inp.seek_subimage(index, 0):
            spec = inp.spec()
            name = spec.getattribute("name") or str(index)
            pixels = np.asarray(inp.read_image(index, 0, 0, spec.nchannels, "float"))
            if spec.getattribute("name"):
                parts[name] = pixels
            else:
                parts.update(_split_by_pass(spec.channelnames, pixels) or {name: pixels})
            index += 1
    finally:
        inp.close()
    return parts


def exr_colour_formats(path) -> set:
    """Storage types ("half", "float") of an EXR's R, G, B, A channels, every part.

    Per channel: 4.5's single-part multilayer file keeps Depth.Z float beside half colour."""
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    assert inp is not None, oiio.geterror()
    formats, index = set(), 0
    try:
        while inp.seek_subimage(index, 0):
            spec = inp.spec()
            formats |= {str(spec.channelformat(i)) for i, n in enumerate(spec.channelnames)
                        if n.rsplit(".", 1)[-1] in ("R", "G", "B", "A")}
            index += 1
    finally:
        inp.close()
    return formats


def _split_by_pass(channels, pixels):
    """{"ViewLayer.Combined": (H, W, C)} from single-part channels named "<pass>.<chan>"."""
    passes = {}
    for i, channel in enumerate(channels):
        if "." in channel:
            passes.setdefault(channel.rsplit(".", 1)[0], []).append(i)
    return {name: pixels.reshape(*pixels.shape[:2], -1)[..., idx] for name, idx in passes.items()}


def read_image(path):
    """(H, W, C) pixels as stored (uint8 for 8-bit PNG), top-down, via OpenImageIO.

    PNG holds straight alpha; OpenImageIO multiplies it in on read unless told not to.
    """
    import OpenImageIO as oiio

    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    inp = oiio.ImageInput.open(str(path), config)
    assert inp is not None, oiio.geterror()
    try:
        spec = inp.spec()
        return np.asarray(inp.read_image(0, 0, 0, spec.nchannels, spec.format))
    finally:
        inp.close()
