"""The demo scene: a capture-like splat object that reveals in, displaces, morphs into a
second splat object and dissolves out, under a keyframed orbiting camera.

Everything is built through the add-on's public Blender layer (splat objects, the effect
stack, the look) and animated with keyframes, so the saved .blend is an ordinary,
editable Splatline scene: scrub it, change a key in the graph editor, render it again.
"""
from __future__ import annotations

import math

import numpy as np

import bpy
from mathutils import Vector

from ...core import framing, procedural
from ...core.framing import Bounds
from ...core.procedural import coherent_order
from ..data.animation import set_interpolation
from ..data.capture_camera import splat_world_points
from ..data.files import import_file
from ..data.pointcloud import new_pointcloud_object

SOURCE_NAME = "Capture"
TARGET_NAME = "Morph Target"
CAMERA_NAME = "Demo Camera"
# Where each act starts, as a fraction of the timeline (the last act runs to the end).
ACTS = {"reveal": (0.0, 0.26), "displace": (0.22, 0.52), "morph": (0.46, 0.76),
        "dissolve": (0.8, 1.0)}


def world_bounds(obj) -> Bounds:
    """World-space extent of the capture, robust to stray splats (2nd-98th percentile)."""
    return framing.robust_bounds(splat_world_points([obj]))


def build(context, *, splats: int = 300_000, target_splats: int | None = None,
          frames: int = 120, fps: int = 24, file=None, degree: int = 3, aspect: float = 16 / 9,
          axes: str = "AUTO"):
    """Fill context.scene with the animated demo; returns (source, target, camera).

    `file`: a splat file to use instead of the procedural torus knot (its SH degree is
    kept up to `degree`; `axes` its axis convention, AUTO: the file's). The morph target is a procedural planet sized to the source.
    `aspect`: the frame's width over height, which the camera distance is fitted to.
    """
    scene = context.scene
    scene.frame_start, scene.frame_end = 1, frames
    scene.render.fps, scene.render.fps_base = fps, 1.0
    if file is None:
        knot = procedural.torus_knot(splats, degree)
        source = new_pointcloud_object(SOURCE_NAME, knot.subset(coherent_order(knot.positions)))
        target_count = splats  # equal counts: the morph pairs by index, in coherent order
    else:
        source = import_file(context, file, max_sh_degree=degree, max_count=splats, axes=axes)
        target_count = max(1, len(source.data.points) * 3 // 4)  # paired by spatial sort
    context.view_layer.update()  # matrix_world of the imported object's axis rotation
    bounds = world_bounds(source)
    target = _add_target(bounds, target_splats or target_count, degree)
    timeline = _Timeline(frames)
    _animate_effects(source, target, bounds, timeline)
    camera = _add_camera(scene, bounds, timeline, aspect)
    return source, target, camera


def _add_target(bounds: Bounds, count: int, degree: int):
    """The planet (unit radius) as wide as most of the capture, hidden from render: the
    morph reads its data, it is never drawn itself."""
    planet = procedural.planet(count, degree)
    target = new_pointcloud_object(TARGET_NAME, planet.subset(coherent_order(planet.positions)))
    radius = 0.45 * float(np.max(bounds.high - bounds.low))
    target.location = Vector(bounds.centre)
    target.scale = (radius, radius, radius)
    target.hide_render = True
    target.hide_viewport = True
    return target


def showcase_frame(frames: int) -> int:
    """The frame for the README still: the reveal three quarters done, its glowing edge
    sweeping over the knot (what splat effects do, in one picture)."""
    start, end = _Timeline(frames).act("reveal")
    return start + round(0.75 * (end - start))


class _Timeline:
    def __init__(self, frames: int):
        self.frames = frames

    def frame(self, fraction: float) -> int:
        return 1 + round(fraction * (self.frames - 1))

    def act(self, name: str) -> tuple[int, int]:
        start, end = ACTS[name]
        return self.frame(start), self.frame(end)


def _key(owner, prop: str, frame: int, value, interpolation: str = "BEZIER") -> None:
    setattr(owner, prop, value)
    owner.keyframe_insert(prop, frame=frame)
    set_interpolation(owner.id_data, interpolation, owner.path_from_id(prop), frame)


def _add_effect(obj, kind: str, name: str):
    """Through the same operator as the panel's + button (it also makes the effect active)."""
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.splatline.effect_add(type=kind)
    effect = obj.splatline.effects[-1]
    effect.name = name
    return effect


def _animate_effects(source, target, bounds: Bounds, timeline: _Timeline) -> None:
    """Reveal sweep (with a glowing edge) -> displace swell -> morph -> noise dissolve."""
    origin_z = float(np.array(source.matrix_world)[2, 3])
    zmin, zmax = bounds.low[2] - origin_z, bounds.high[2] - origin_z
    edge = 0.12 * (zmax - zmin) + 1e-6
    size = bounds.size

    reveal = _add_effect(source, "REVEAL", "Reveal In")
    reveal.reveal_shape, reveal.edge_width = "PLANE", edge
    reveal.glow_color, reveal.glow_strength = (1.0, 0.55, 0.15), 1.5
    start, end = timeline.act("reveal")
    _key(reveal, "progress", start, zmin - edge, "LINEAR")
    _key(reveal, "progress", end, zmax + edge, "LINEAR")

    displace = _add_effect(source, "DISPLACE", "Displace")
    displace.frequency, displace.speed, displace.seed = 8.0 / size, 0.8, 7
    start, end = timeline.act("displace")
    _key(displace, "amplitude", start, 0.0)
    _key(displace, "amplitude", (start + end) // 2, 0.05 * size)
    _key(displace, "amplitude", end, 0.0)

    morph = _add_effect(source, "MORPH", "Morph")
    morph.target = target
    start, end = timeline.act("morph")
    _key(morph, "amount", start, 0.0)
    _key(morph, "amount", end, 1.0)

    dissolve = _add_effect(source, "REVEAL", "Dissolve Out")
    dissolve.reveal_shape, dissolve.invert, dissolve.seed = "NOISE", True, 3
    dissolve.frequency, dissolve.edge_width = 10.0 / size, 0.12
    dissolve.glow_color, dissolve.glow_strength = (0.3, 0.6, 1.0), 1.0
    start, end = timeline.act("dissolve")
    _key(dissolve, "progress", start, -0.15, "LINEAR")
    _key(dissolve, "progress", end, 1.15, "LINEAR")


def _add_camera(scene, bounds: Bounds, timeline: _Timeline, aspect: float):
    """An orbit of a third of a turn that dollies in and back out and sinks a little, keyed
    every few frames on location and rotation (no constraint), so it edits like any
    hand-keyed camera. The distance fits the capture's width and height into the frame."""
    data = bpy.data.cameras.new(CAMERA_NAME)
    data.lens, data.sensor_fit, data.sensor_width = 35.0, "AUTO", 36.0
    data.clip_start = max(1e-3, 0.01 * bounds.size)
    data.clip_end = 100.0 * bounds.size
    camera = bpy.data.objects.new(CAMERA_NAME, data)
    scene.collection.objects.link(camera)
    scene.camera = camera
    fit = _fit_distance(bounds, data, aspect)
    centre = Vector(bounds.centre)
    step = max(1, timeline.frames // 16)
    frames = list(range(1, timeline.frames + 1, step))
    if frames[-1] != timeline.frames:
        frames.append(timeline.frames)
    previous = None
    for frame in frames:
        u = (frame - 1) / max(1, timeline.frames - 1)
        angle = -math.pi / 2 + math.pi * 0.6 * u
        radius = fit * (1.3 - 0.3 * math.sin(math.pi * u))
        height = radius * math.tan(math.radians(18.0 - 10.0 * u))
        camera.location = centre + Vector((radius * math.cos(angle), radius * math.sin(angle), height))
        look = (centre - camera.location).to_track_quat("-Z", "Y")
        euler = look.to_euler("XYZ", previous) if previous is not None else look.to_euler("XYZ")
        camera.rotation_euler = previous = euler
        camera.keyframe_insert("location", frame=frame)
        camera.keyframe_insert("rotation_euler", frame=frame)
    return camera


def _fit_distance(bounds: Bounds, camera_data, aspect: float) -> float:
    """framing.fit_box_distance for this camera's lens, sensor and frame aspect."""
    half = camera_data.sensor_width / 2 / camera_data.lens  # tan of the larger half-angle
    tan_x, tan_y = (half, half / aspect) if aspect >= 1.0 else (half * aspect, half)
    return framing.fit_box_distance(bounds, tan_x, tan_y)
