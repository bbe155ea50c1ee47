"""Cameras for splat objects: an orbit, front or side framing, or a SuperSplat camera track.

Thin: the framing math and the track reader live in core (framing.py, camtrack.py); this
module turns their matrices into a keyed Blender camera. Each key sets matrix_world and
keys location and rotation (euler, kept continuous), so the camera edits like a hand-keyed one.
"""
from __future__ import annotations

import math

import numpy as np

import bpy
from mathutils import Matrix

from ...core import camtrack, facing, framing
from ...core.visible_bounds import visible_bounds
from .animation import action_fcurves, set_interpolation
from .files import object_axes
from .pointcloud import read_opacities_scales_rotations, read_positions

CAMERA_NAME = "Splat Camera"
LENS_MM, SENSOR_MM = 50.0, 36.0


def splat_world_points(objects, own_transforms=False) -> np.ndarray:
    """Every object's splat centres in world space (float64). The centres alone are read:
    a whole SplatSet read back (every SH plane, transposed) was 1.1 s of CPU of a 1M-splat
    degree-3 import's framing (bench/import_bench.py). own_transforms: the objects' own
    transforms place them (see _own_transforms), not their last evaluated matrix_world."""
    parts = []
    for obj in objects:
        matrix = np.array(obj.matrix_basis if own_transforms else obj.matrix_world, np.float64)
        world = framing.rows_times(read_positions(obj.data), matrix[:3, :3].T)
        world += matrix[:3, 3]
        parts.append(world)
    if len(parts) == 1:  # one capture (a command-line import): no 24 MB copy a million
        return parts[0]
    return np.concatenate(parts) if parts else np.zeros((0, 3))


def _splat_looks(objects, own_transforms):
    """What framing reads besides the centres, in splat_world_points' order: each splat's
    opacity and world-scaled scales (which splats show: core/visible_bounds.py), and for a
    strided sample (its rows) the world normals and weights of core/facing.py."""
    stride = facing.sample_stride(sum(len(obj.data.points) for obj in objects))
    parts, offset = [], 0
    for obj in objects:
        matrix = np.array(obj.matrix_basis if own_transforms else obj.matrix_world, np.float64)[:3, :3]
        alpha, scales, rotations = read_opacities_scales_rotations(obj.data)
        normals, flatness = facing.splat_normals(rotations[::stride], scales[::stride], matrix)
        size = abs(float(np.linalg.det(matrix))) ** (1.0 / 3.0)  # a uniform scale's factor
        parts.append((alpha, scales * size, normals, flatness * alpha[::stride],
                      offset + np.arange(0, len(alpha), stride)))
        offset += len(alpha)
    if not parts:
        return np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64)
    return tuple(part[0] if len(parts) == 1 else np.concatenate(part) for part in zip(*parts))


def _own_transforms(objects) -> bool:
    """Whether each object sits where its own location, rotation and scale put it (no parent,
    constraint, animation or rigid body): its matrix_basis is then the matrix_world Blender
    would evaluate, without a depsgraph update, which costs 0.3 s of CPU for a fresh 1M-splat
    object on Blender 5.3 (and what the command line frames is a fresh import)."""
    return not any(obj.parent or len(obj.constraints) or obj.animation_data or obj.rigid_body
                   for obj in objects)


def new_camera(scene, name=CAMERA_NAME):
    """A camera object linked to the scene and made its active camera."""
    data = bpy.data.cameras.new(name)
    data.lens, data.sensor_width, data.sensor_fit = LENS_MM, SENSOR_MM, "AUTO"
    obj = bpy.data.objects.new(name, data)
    scene.collection.objects.link(obj)
    scene.camera = obj
    return obj


def _tan_halves(scene, data) -> tuple[float, float]:
    """tan of the half fields of view the frame will have (sensor fit AUTO)."""
    width = scene.render.resolution_x * scene.render.pixel_aspect_x
    height = scene.render.resolution_y * scene.render.pixel_aspect_y
    larger = data.sensor_width / 2.0 / data.lens
    return (larger, larger * height / width) if width >= height else (larger * width / height, larger)


def add_framing_camera(context, objects, mode="orbit", frame_start=None, frame_end=None,
                       fill=framing.FILL, elevation=None, lens=None, fov=None, azimuth=0.0):
    """A camera framing `objects` (splat objects) so the bounds of their splats that show
    (core/visible_bounds.py) span `fill` of the frame's shorter side: "orbit" keys one full
    turn over the frame range, a key a frame; "capture", "front" and "side" are one still
    key (core/framing.py says what they mean). elevation: degrees above the capture's
    horizon (default: ELEVATION_DEG for the orbit, level for a still view); azimuth:
    degrees every view turns counter-clockwise about up (seen from above) from where it
    would stand; lens (mm) or fov (degrees, across the frame's longer side): default
    LENS_MM. Returns the camera object."""
    if mode not in framing.MODES:
        raise ValueError(f"camera mode {mode!r} is not one of {framing.MODES}")
    scene = context.scene
    own = _own_transforms(objects)
    if not own:
        context.view_layer.update()  # matrix_world of objects Blender places
    start = scene.frame_start if frame_start is None else frame_start
    end = scene.frame_end if frame_end is None else frame_end
    points = splat_world_points(objects, own)
    opacities, scales, normals, weights, rows = _splat_looks(objects, own)
    bounds = visible_bounds(points, opacities, scales)
    placed = objects[0].matrix_basis if own else objects[0].matrix_world
    up, ahead = framing.capture_axes(object_axes(objects[0]), np.array(placed))
    if mode != "capture":
        faces = facing.facing(points[rows], normals, weights, bounds.centre, up)
        ahead = framing.front_direction(points, bounds, up, ahead, faces)
    forward = framing.turned(ahead, up, azimuth)
    camera = new_camera(scene)
    if lens is not None:
        camera.data.lens = lens
    if fov is not None:
        camera.data.angle = math.radians(fov)  # sensor fit AUTO: the longer side's field
    if elevation is None:
        elevation = framing.ELEVATION_DEG if mode == "orbit" else 0.0
    azimuths = framing.orbit_azimuths() if mode == "orbit" else (framing.view_azimuth(mode),)
    distance = framing.fill_distance(bounds, up, forward, *_tan_halves(scene, camera.data),
                                     fill, elevation, azimuths)
    camera.data.clip_start, camera.data.clip_end = framing.clip_range(bounds, distance)
    if mode == "orbit":
        count = end - start + 1
        poses = list(zip(range(start, end + 1),
                         framing.orbit_poses(bounds, up, forward, distance, count, elevation)))
    else:
        poses = [(start, framing.front_pose(bounds, up, forward, distance, elevation, azimuths[0]))]
    key_poses(camera, poses)
    set_interpolation(camera, "LINEAR")  # a key a frame needs no easing between keys
    return camera


def key_poses(camera, poses) -> None:
    """Key location and rotation at every (frame, matrix) of `poses`, as _key would one by
    one, in time linear in their number: the first key through keyframe_insert (it makes
    the action, its slot and the F-curves, layered or not), the rest added at once with
    keyframe_points.add and foreach_set. keyframe_insert a frame was quadratic: 17 s for
    the orbit of --frames 1-10000, minutes for 1-100000 (issue 26)."""
    poses = list(poses)
    if not poses:
        return
    _key(camera, *poses[0])
    if len(poses) == 1:
        return
    frames = np.array([frame for frame, _ in poses], np.float64)
    values = np.empty((len(poses), 6), np.float64)
    previous = camera.rotation_euler.copy()
    for i, (_, matrix) in enumerate(poses):
        m = Matrix(np.asarray(matrix).tolist())
        location, rotation, _scale = m.decompose()
        euler = rotation.to_matrix().to_euler("XYZ", previous)  # no 360 degree jumps between keys
        values[i, :3] = location
        values[i, 3:] = euler
        previous = euler
    curves = {(c.data_path, c.array_index): c for c in action_fcurves(camera)}
    for column, (path, index) in enumerate([("location", i) for i in range(3)] +
                                           [("rotation_euler", i) for i in range(3)]):
        points = curves[(path, index)].keyframe_points
        points.add(len(poses) - 1)
        co = np.column_stack([frames, values[:, column]]).astype(np.float32).ravel()
        for name in ("co", "handle_left", "handle_right"):
            points.foreach_set(name, co)
        curves[(path, index)].update()


def set_frame_rate(scene, fps: float) -> None:
    """The scene's rate as Blender keeps it, an integer rate and a divisor: 29.97 is 30 / 1.001
    (a camera track's rate, or the command line's --fps)."""
    scene.render.fps = max(1, round(fps))
    scene.render.fps_base = scene.render.fps / fps


def add_track_camera(context, track: camtrack.CameraTrack, reference=None, frame_offset=None,
                     name=CAMERA_NAME):
    """A camera keyed from a camera track. The track's world is tied to `reference`, a splat
    object (its matrix_world, axis rotation included); without one, to an unmoved RDF
    capture. Key k lands on frame frame_offset + k (default: the scene's start frame)."""
    scene = context.scene
    context.view_layer.update()  # the reference's matrix_world, if it was just imported or moved
    capture_to_world = _capture_to_world(reference)
    poses = camtrack.blender_poses(track, capture_to_world)
    offset = scene.frame_start if frame_offset is None else frame_offset
    camera = new_camera(scene, name)
    camera.data.sensor_fit = "VERTICAL" if track.fov_fit == camtrack.FOV_VERTICAL else "AUTO"
    camera.data.sensor_height = SENSOR_MM
    _track_clip(camera.data, poses, capture_to_world, reference)
    for frame, matrix, fov in poses:
        camera.data.lens = SENSOR_MM / 2.0 / math.tan(math.radians(fov) / 2.0)
        camera.data.keyframe_insert("lens", frame=offset + frame)
        _key(camera, offset + frame, matrix)
    return camera  # Blender's Bezier between sparse keys, as SuperSplat eases with a spline


def _capture_to_world(reference) -> np.ndarray:
    """Matrix from the capture's RDF frame to the world: the object's matrix with its file
    axes undone (object_axes says which frame its data holds), or the plain RDF rotation."""
    from ...core.axes import matrix_for

    if reference is None:
        matrix = np.eye(4)
        matrix[:3, :3] = matrix_for("RDF")
        return matrix
    file_from_rdf = np.eye(4)
    axes = object_axes(reference)
    file_from_rdf[:3, :3] = matrix_for(axes).T @ matrix_for("RDF")
    return np.array(reference.matrix_world, np.float64) @ file_from_rdf


def _track_clip(data, poses, capture_to_world, reference) -> None:
    """Clip planes that hold the scene the track looks at: from the eye-to-target distances,
    and the capture's extent when a reference object is given."""
    reach = max(float(np.linalg.norm(m[:3, 3])) for _, m, _ in poses) + 1.0
    if reference is not None:
        reach += framing.robust_bounds(splat_world_points([reference])).radius
    data.clip_start, data.clip_end = 0.01, max(100.0, 4.0 * reach)


def _key(camera, frame, matrix) -> None:
    previous = camera.rotation_euler.copy() if camera.animation_data else None
    camera.matrix_world = Matrix(np.asarray(matrix).tolist())
    if previous is not None:  # no 360 degree jumps between keys
        camera.rotation_euler = camera.rotation_euler.to_matrix().to_euler("XYZ", previous)
    camera.keyframe_insert("location", frame=frame)
    camera.keyframe_insert("rotation_euler", frame=frame)
