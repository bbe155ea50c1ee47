"""Camera tracks from SuperSplat and splat-transform: read them, put them in Blender's world.

Shapes read (facts from playcanvas/supersplat, supersplat-viewer and splat-transform):
- SuperSplat viewer `settings.json` (v2): `animTracks[0].keyframes` holds `times` (frames),
  and `values.position`/`target` (flat xyz lists) and `fov` (one per key), with the track's
  `frameRate`. v1 files (no `version`) have no per-key fov (the top-level `camera.fov`
  applies) and, without a frameRate, times in seconds at 30 fps.
- SuperSplat project: an `.ssproj` zip, or its `document.json`: `poseSets[0].poses` of
  `{frame, position, target, fov}`, `timeline.frameRate`, and `splats[0]` the capture's
  entity transform (`position`, `rotation` as xyzw, `scale`).
- A plain list: `{frameRate, frames: [{position, target, fov, up}]}`, one entry per frame
  (or with its own `frame`), as splat-transform's camera options: `fov` is the vertical
  field of view in degrees, `up` defaults to +y.

Coordinates: every shape is in the PlayCanvas world (y up, right-handed, the camera looks
down -z). SuperSplat and splat-transform load a capture with a 180 degree turn about z
(splat-transform's Transform.PLY: the file's y-down becomes y-up), so a point p in a
capture's own RDF frame sits at Rz(180) p there, unless a project moved the capture. Field
of view: SuperSplat's fov spans the larger image side (its `horizontalFov = width >
height`), which is Blender's sensor fit AUTO; the plain list's is vertical.
"""
from __future__ import annotations

import io
import json
import math
import os
import zipfile
from dataclasses import dataclass, field

import numpy as np

from .errors import SplatFormatError
from .matrix_inverse import inverse4
from .quaternion import to_matrix

PLY_TO_PLAYCANVAS = np.diag([-1.0, -1.0, 1.0, 1.0])  # Rz(180): capture RDF -> PlayCanvas world
FOV_AUTO, FOV_VERTICAL = "AUTO", "VERTICAL"
_MAX_BYTES = 64 << 20  # a camera track is a few kB; refuse to parse anything absurd


@dataclass
class CameraKey:
    frame: float  # 0-based, on the track's own timeline
    position: np.ndarray  # (3,) PlayCanvas world
    target: np.ndarray
    fov: float  # degrees
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 1.0, 0.0]))


@dataclass
class CameraTrack:
    keys: list  # CameraKey, sorted by frame
    frame_rate: float
    fov_fit: str  # FOV_AUTO (larger side) or FOV_VERTICAL
    capture_to_playcanvas: np.ndarray = field(default_factory=lambda: PLY_TO_PLAYCANVAS.copy())
    shape: str = ""

    @property
    def last_frame(self) -> int:
        return int(math.ceil(self.keys[-1].frame))


def read_track(path) -> CameraTrack:
    """Read any shape above; every problem is a SplatFormatError naming the file."""
    data = _load_json(path)
    if not isinstance(data, dict):
        raise SplatFormatError(path, f"expected a JSON object, found {type(data).__name__}")
    try:
        if "animTracks" in data:
            track = _from_settings(data)
        elif "poseSets" in data:
            track = _from_document(data)
        elif "frames" in data:
            track = _from_frames(data)
        else:
            raise ValueError("not a camera track: no 'animTracks' (SuperSplat settings.json), "
                             "'poseSets' (SuperSplat document.json) or 'frames' list")
    except (ValueError, TypeError, KeyError, IndexError) as exc:
        raise SplatFormatError(path, _reason(exc)) from None
    return track


def _reason(exc) -> str:
    return f"missing field {exc.args[0]!r}" if isinstance(exc, KeyError) else str(exc)


def _load_json(path):
    try:
        size = os.path.getsize(path)
        if size > _MAX_BYTES:
            raise SplatFormatError(path, f"{size} bytes is too large for a camera track")
        if zipfile.is_zipfile(path):  # an .ssproj: the camera lives in document.json
            with zipfile.ZipFile(path) as archive:
                if "document.json" not in archive.namelist():
                    raise SplatFormatError(path, "zip holds no document.json (not a SuperSplat project)")
                if archive.getinfo("document.json").file_size > _MAX_BYTES:
                    raise SplatFormatError(path, "document.json is too large for a camera track")
                text = archive.read("document.json")
        else:
            with open(path, "rb") as f:
                text = f.read()
        return json.load(io.BytesIO(text))
    except FileNotFoundError:
        raise SplatFormatError(path, "no such file") from None
    except IsADirectoryError:
        raise SplatFormatError(path, "is a directory") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise SplatFormatError(path, f"not valid JSON ({exc})") from None
    except zipfile.BadZipFile as exc:
        raise SplatFormatError(path, f"broken zip ({exc})") from None
    except OSError as exc:
        raise SplatFormatError(path, exc.strerror or str(exc)) from None


def _vec3(value, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64) if isinstance(value, (list, tuple)) else None
    if arr is None or arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{what}: expected three finite numbers, found {value!r}")
    return arr


def _number(value, what: str, low=None, high=None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"{what}: expected a number, found {value!r}")
    if (low is not None and value <= low) or (high is not None and value >= high):
        raise ValueError(f"{what}: {value!r} is outside ({low}, {high})")
    return float(value)


def _fov(value, what: str) -> float:
    return _number(value, what, 0.0, 180.0)


def _finish(keys, frame_rate, fov_fit, shape, capture_to_playcanvas=None) -> CameraTrack:
    if not keys:
        raise ValueError("the track has no keyframes")
    for key in keys:
        view = key.target - key.position
        if np.linalg.norm(view) < 1e-9:
            raise ValueError(f"frame {key.frame:g}: position and target are the same point")
        if np.linalg.norm(np.cross(view / np.linalg.norm(view), key.up)) < 1e-9:
            raise ValueError(f"frame {key.frame:g}: the camera looks along its up vector")
    keys = sorted(keys, key=lambda k: k.frame)
    track = CameraTrack(keys, _number(frame_rate, "frameRate", 0.0), fov_fit, shape=shape)
    if capture_to_playcanvas is not None:
        track.capture_to_playcanvas = capture_to_playcanvas
    return track


def _from_settings(data) -> CameraTrack:
    tracks = data["animTracks"]
    if not isinstance(tracks, list) or not tracks:
        raise ValueError("'animTracks' is empty: the settings hold no camera animation")
    track = tracks[0]
    kf = track["keyframes"]
    times, values = kf["times"], kf["values"]
    if not isinstance(times, list):
        raise ValueError("animTracks[0].keyframes.times: expected a list")
    frame_rate = track.get("frameRate")
    scale = 1.0
    if data.get("version") is None and not frame_rate:  # v1 without frameRate: seconds at 30 fps
        frame_rate, scale = 30.0, 30.0
    default_fov = (data.get("camera") or {}).get("fov", 60.0)
    fovs = values.get("fov") or [default_fov] * len(times)
    keys = []
    for i, t in enumerate(times):
        what = f"animTracks[0] key {i}"
        keys.append(CameraKey(
            _number(t, f"{what} time") * scale,
            _vec3(values["position"][3 * i:3 * i + 3], f"{what} position"),
            _vec3(values["target"][3 * i:3 * i + 3], f"{what} target"),
            _fov(fovs[i] if i < len(fovs) else None, f"{what} fov")))
    return _finish(keys, frame_rate, FOV_AUTO, "settings.json")


def _from_document(data) -> CameraTrack:
    sets = data["poseSets"]
    if not isinstance(sets, list) or not sets or not sets[0].get("poses"):
        raise ValueError("'poseSets' holds no camera poses")
    frame_rate = (data.get("timeline") or {}).get("frameRate", 30)
    default_fov = (data.get("camera") or {}).get("fov", 60.0)
    keys = []
    for i, pose in enumerate(sets[0]["poses"]):
        what = f"poseSets[0].poses[{i}]"
        frame = pose.get("frame")  # older projects: one pose per second (SuperSplat's fallback)
        keys.append(CameraKey(
            _number(frame if frame is not None else i * frame_rate, f"{what}.frame"),
            _vec3(pose["position"], f"{what}.position"), _vec3(pose["target"], f"{what}.target"),
            _fov(pose.get("fov", default_fov), f"{what}.fov")))
    return _finish(keys, frame_rate, FOV_AUTO, "document.json", _document_transform(data))


def _document_transform(data) -> np.ndarray:
    """The first capture's entity transform in a project (SuperSplat lets the user move it)."""
    splats = data.get("splats")
    if not isinstance(splats, list) or not splats or not isinstance(splats[0], dict):
        return PLY_TO_PLAYCANVAS.copy()
    doc = splats[0]
    x, y, z, w = (float(v) for v in doc.get("rotation", (0.0, 0.0, 1.0, 0.0)))  # xyzw
    matrix = np.eye(4)
    matrix[:3, :3] = _quat_matrix(w, x, y, z) * _vec3(doc.get("scale", [1, 1, 1]), "splats[0].scale")
    matrix[:3, 3] = _vec3(doc.get("position", [0, 0, 0]), "splats[0].position")
    return matrix


def _quat_matrix(w, x, y, z) -> np.ndarray:
    r, ok = to_matrix(np.array([[w, x, y, z]], np.float64))
    if not ok[0] or np.linalg.norm([w, x, y, z]) < 1e-12:
        raise ValueError("splats[0].rotation: not a rotation quaternion")
    return r[0]


def _from_frames(data) -> CameraTrack:
    frames = data["frames"]
    if not isinstance(frames, list):
        raise ValueError("'frames': expected a list of {position, target, fov, up}")
    keys = []
    for i, entry in enumerate(frames):
        what = f"frames[{i}]"
        if not isinstance(entry, dict):
            raise ValueError(f"{what}: expected an object, found {type(entry).__name__}")
        up = _vec3(entry.get("up", [0.0, 1.0, 0.0]), f"{what}.up")
        if np.linalg.norm(up) < 1e-12:
            raise ValueError(f"{what}.up: zero vector")
        keys.append(CameraKey(
            _number(entry.get("frame", i), f"{what}.frame"),
            _vec3(entry["position"], f"{what}.position"), _vec3(entry["target"], f"{what}.target"),
            _fov(entry.get("fov", 60.0), f"{what}.fov"), up))
    return _finish(keys, data.get("frameRate", 30), FOV_VERTICAL, "frames")


def blender_poses(track: CameraTrack, capture_to_world) -> list:
    """[(frame, camera-to-world 4x4 in Blender's world, fov degrees)] for each key.

    capture_to_world: the splat object's matrix taking its capture RDF frame to Blender's
    world (the object's matrix_world, its axis rotation included). A track point q maps to
    capture_to_world @ inv(capture_to_playcanvas) @ q; the camera looks at the mapped
    target with the mapped up, Blender's camera looking down -z.
    """
    from .camera import look_at

    # inverse4, not LAPACK's inv: a key each would wake OpenBLAS's spinning threads
    to_world = np.asarray(capture_to_world, np.float64) @ inverse4(track.capture_to_playcanvas)
    linear = to_world[:3, :3]
    poses = []
    for key in track.keys:
        eye = linear @ key.position + to_world[:3, 3]
        target = linear @ key.target + to_world[:3, 3]
        poses.append((key.frame, inverse4(look_at(eye, target, linear @ key.up)), key.fov))
    return poses
