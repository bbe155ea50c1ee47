"""The rows of the final-frame table (bench/final_frame_bench.py), on the playbot scene
(bench/playbot_scene.py: a figure at the origin in a 6 x 6 x 2.6 m room).

A row names the renderer (with or without the Z pass), the before worker's name for the
same frame (None: the old renderer has no such feature), the states it renders (items and
camera; more than one are sub-frames averaged as the engine does, core/shutter.Average)
and the windows of the frame its error is measured on (the reference renders exactly
those pixels of the same frame, reference.render(window=...)).
- + DOF: Blender's thin lens at f/FSTOP on the lens a 36 mm sensor gives the bench
  camera's 60 degree field of view (31.2 mm: lens radius 11 mm), focused on the figure's
  centre (2.44 m): the far wall (5.5 m) blurs with a CoC radius of about 4 px, the floor
  before the figure by 1-2 px, the figure stays sharp. Also measured against the lens itself on a
  small crop (lens_figures): the mean of LENS_SAMPLES exact pinhole renders over the
  aperture (core/dof.lens_camera).
- + motion blur: BLUR_SAMPLES sub-frames of a SHUTTER-frame centred shutter
  (core/shutter.sub_frame_times), the figure turning 10 degrees a frame about its axis
  and the camera dollying 0.2 m a frame sideways; each sub-frame a full render.
- equirect: Blender's full-sphere equirectangular camera inside the room, level, looking
  at the figure; the ceiling and floor fill the pole rows, a wall the seam. Its windows:
  the centre, a 128 px tile across the seam (64 px at each edge), both poles' rows, and
  one off-centre tile.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from addon.core import dof, reference, shutter
from addon.core.camera import Camera, equirect_camera, look_at
from bench.common import crop, psnr, reaching

TILE = 128
TILES = tuple((x, y, TILE, TILE) for x, y in ((896, 476), (256, 160), (1536, 160), (256, 792), (1536, 792)))
PANORAMA_TILES = ((896, 476, TILE, TILE), (0, 476, TILE // 2, TILE), (1920 - TILE // 2, 476, TILE // 2, TILE),
                  (896, 0, TILE, TILE), (896, 1080 - TILE, TILE, TILE), (1536, 300, TILE, TILE))
PANORAMA_NAMES = ("centre", "seam (left edge)", "seam (right edge)", "north pole", "south pole", "off-centre")
FIGURE_CENTRE = (0.0, 0.0, 1.0)
FSTOP = 1.4
LENS_SAMPLES = 64
LENS_CROP = 48
BLUR_SAMPLES = 8
SHUTTER = 0.5
PANORAMA_EYE = (0.3, -1.6, 1.2)


def still(items, cam) -> list:
    return [(items, cam)]


def dof_camera(cam: Camera) -> Camera:
    focus = float(cam.project(np.array([FIGURE_CENTRE]))[0, 2])
    lens_mm = 36.0 * cam.fx / cam.width  # the focal length a 36 mm wide sensor needs
    return dataclasses.replace(cam, defocus=dof.from_fstop(lens_mm, FSTOP, focus))


def with_dof(items, cam) -> list:
    return [(items, dof_camera(cam))]


def moved(items, cam: Camera, time: float) -> tuple:
    """Items and camera at `time` (frames from the frame): the figure (items[0], standing
    on the origin) turned about z, the camera moved +x (its world_to_camera shifted -x)."""
    a = math.radians(10.0) * time
    turn = np.eye(4)
    turn[:2, :2] = [[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]
    figure = dataclasses.replace(items[0], world=turn @ items[0].world)
    dolly = np.eye(4)
    dolly[0, 3] = -0.2 * time
    return [figure, *items[1:]], dataclasses.replace(cam, world_to_camera=cam.world_to_camera @ dolly)


def motion_blur(items, cam) -> list:
    return [moved(items, cam, t) for t in shutter.sub_frame_times(0, SHUTTER, "CENTER", BLUR_SAMPLES)]


def panorama(items, cam) -> list:
    eye = np.array(PANORAMA_EYE)
    target = (FIGURE_CENTRE[0], FIGURE_CENTRE[1], eye[2])
    return [(items, equirect_camera(look_at(eye, target), cam.width, cam.height, near=cam.near, far=cam.far))]


@dataclass(frozen=True)
class Row:
    label: str
    depth: bool = False                      # the renderer with the Z pass
    before: str | None = None                # the before worker's frame name; None: new
    states: Callable = still                 # (items, camera) -> [(items, camera)], averaged
    windows: tuple = TILES                   # (x, y, w, h) error windows of the frame
    window_names: tuple = ()                 # given: the error is also printed per window


ROWS = (
    Row("colour", before="colour"),
    Row("+ Z", depth=True, before="z"),
    Row("+ DOF", states=with_dof),
    Row(f"+ motion blur ({BLUR_SAMPLES} samples)", states=motion_blur),
    Row("equirect", states=panorama, windows=PANORAMA_TILES, window_names=PANORAMA_NAMES),
)


def small(cam: Camera) -> Camera:
    """The same camera at 1/30 the size (a warm-up frame: shaders, uploads)."""
    k = 30.0
    return dataclasses.replace(cam, width=max(1, round(cam.width / k)), height=max(1, round(cam.height / k)),
                               fx=cam.fx / k, fy=cam.fy / k, cx=cam.cx / k, cy=cam.cy / k)


def lens_window(cam: Camera) -> tuple:
    """A LENS_CROP square on the figure's right arm's outer edge: the arm in focus, the
    far wall beside it blurred."""
    u, v, _ = cam.project(np.array([[0.51, 0.0, 1.05]]))[0]
    half = LENS_CROP // 2
    return (int(round(u)) - half, int(round(v)) - half, LENS_CROP, LENS_CROP)


def lens_figures(dof_frame: np.ndarray, items, cam: Camera) -> dict:
    """DOF against the lens itself on lens_window: (PSNR, max abs) against the mean of
    LENS_SAMPLES exact pinhole reference renders over the aperture, of the GL frame, of
    the reference's CoC widening (the same approximation in float64) and of no DOF."""
    dcam = dof_camera(cam)
    win = lens_window(dcam)
    near = reaching(items, dcam, win, margin=4.0)  # the widened quads cover every lens shift
    frames = [reference.render(near, dof.lens_camera(dcam, p), window=win).rgba
              for p in dof.lens_samples(LENS_SAMPLES)]
    lens = np.mean(np.asarray(frames, np.float64), axis=0)
    widened = reference.render(near, dcam, window=win).rgba
    pinhole = reference.render(near, dataclasses.replace(dcam, defocus=None), window=win).rgba
    out = {"window": win}
    for name, img in (("gl", crop(dof_frame, win)), ("reference CoC", widened), ("pinhole", pinhole)):
        out[name] = (psnr(img, lens), float(np.abs(np.asarray(img, np.float64) - lens).max()))
    return out
