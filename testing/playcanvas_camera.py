"""PlayCanvas's own camera model (splat-transform's render camera: forward = target - eye,
right = forward x up, down = forward x right, y up world), independent of the code that maps
camera tracks into Blender, and a SuperSplat settings.json track to frame with it."""
from __future__ import annotations

import math

import numpy as np

W, H = 320, 180


def playcanvas_pixel(point_pc, eye, target, up, fov_deg, fit):
    """Pixel of a PlayCanvas-world point, as PlayCanvas (fit AUTO: fov on the larger side) or
    splat-transform (VERTICAL) draws it."""
    eye, target, up, p = (np.asarray(v, float) for v in (eye, target, up, point_pc))
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    d = p - eye
    x, y, z = d @ right, d @ down, d @ forward
    span = W if (fit == "AUTO" and W > H) else H
    f = span / 2 / math.tan(math.radians(fov_deg) / 2)
    return np.array([W / 2 + f * x / z, H / 2 + f * y / z])


SETTINGS = {"version": 2, "animTracks": [{
    "name": "cameraAnim", "duration": 2, "frameRate": 24, "loopMode": "repeat",
    "interpolation": "spline", "smoothness": 1,
    "keyframes": {"times": [0, 24], "values": {
        "position": [1, 2, 6, -5, 1, 1], "target": [0, 1.5, 0, 0, 1, 0], "fov": [50, 35]}}}]}
