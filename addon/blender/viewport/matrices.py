"""OpenGL matrices for a core Camera, so the gpu path can draw what a Camera sees."""
from __future__ import annotations

import numpy as np

from ...core.camera import Camera


def projection_matrix(camera: Camera) -> np.ndarray:
    """(4, 4) clip matrix with the camera's focal lengths, principal point (shift) and clips.

    Inverse of gpu_draw.view_constants: fx = W/2 P00, cx = W/2 (1 - P02) (perspective)
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
