"""A core Camera as OpenGL clip matrices and back: the gpu-module viewport draws what a
Camera sees through a projection matrix, and reads a Blender view's projection matrix
back into the Camera terms (focal lengths, principal point, clips) its shaders use."""
from __future__ import annotations

import numpy as np

from .camera import Camera


def projection_matrix(camera: Camera) -> np.ndarray:
    """(4, 4) clip matrix with the camera's focal lengths, principal point (shift) and clips.

    Inverse of camera_from_projection: fx = W/2 P00, cx = W/2 (1 - P02) (perspective)
    or W/2 (1 + P03) (ortho), and the same for y with the image's y pointing down.
    """
    w, h, n, f = camera.width, camera.height, camera.near, camera.far
    p = np.zeros((4, 4))
    p[0, 0], p[1, 1] = 2.0 * camera.fx / w, 2.0 * camera.fy / h
    if camera.ortho:
        p[0, 3], p[1, 3] = 2.0 * camera.cx / w - 1.0, 1.0 - 2.0 * camera.cy / h
        p[2, 2], p[2, 3], p[3, 3] = -2.0 / (f - n), -(f + n) / (f - n), 1.0
    else:
        p[0, 2], p[1, 2] = 1.0 - 2.0 * camera.cx / w, 2.0 * camera.cy / h - 1.0
        p[2, 2], p[2, 3], p[3, 2] = -(f + n) / (f - n), -2.0 * f * n / (f - n), -1.0
    return p


def is_ortho(projection) -> bool:
    p = np.asarray(projection, np.float64)
    return abs(p[3, 3] - 1.0) < 1e-9 and abs(p[3, 2]) < 1e-12


def camera_from_projection(projection, width: int, height: int,
                           world_to_camera=None) -> Camera:
    """The Camera an OpenGL projection matrix describes for a width x height target."""
    p = np.asarray(projection, np.float64)
    ortho = is_ortho(p)
    fx, fy = 0.5 * width * p[0, 0], 0.5 * height * p[1, 1]
    if ortho:
        cx, cy = 0.5 * width * (1.0 + p[0, 3]), 0.5 * height * (1.0 - p[1, 3])
        near = (p[2, 3] + 1.0) / p[2, 2]
        far = (p[2, 3] - 1.0) / p[2, 2]
    else:
        cx, cy = 0.5 * width * (1.0 - p[0, 2]), 0.5 * height * (1.0 + p[1, 2])
        near = p[2, 3] / (p[2, 2] - 1.0)
        far = p[2, 3] / (p[2, 2] + 1.0)
    view = np.eye(4) if world_to_camera is None else np.asarray(world_to_camera, np.float64)
    return Camera(view, int(width), int(height), float(fx), float(fy), float(cx), float(cy),
                  float(near), float(far), ortho)
