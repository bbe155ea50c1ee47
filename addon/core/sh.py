"""Real spherical harmonics up to degree 3, as in INRIA's 3DGS (same signs and order)."""
from __future__ import annotations

import numpy as np

C0 = 0.28209479177387814
C1 = 0.4886025119029199
C2 = (1.0925484305920792, -1.0925484305920792, 0.31539156525252005,
      -1.0925484305920792, 0.5462742152960396)
C3 = (-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154,
      -0.4570457994644658, 1.445305721320277, -0.5900435899266435)


def sh_basis(dirs: np.ndarray, degree: int) -> np.ndarray:
    """(N, 3) unit directions -> (N, (degree+1)^2) basis values, DC first."""
    d = np.asarray(dirs)
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    cols = [np.full_like(x, C0)]
    if degree >= 1:
        cols += [-C1 * y, C1 * z, -C1 * x]
    if degree >= 2:
        xx, yy, zz, xy, yz, xz = x * x, y * y, z * z, x * y, y * z, x * z
        cols += [C2[0] * xy, C2[1] * yz, C2[2] * (2 * zz - xx - yy), C2[3] * xz, C2[4] * (xx - yy)]
    if degree >= 3:
        cols += [
            C3[0] * y * (3 * xx - yy),
            C3[1] * xy * z,
            C3[2] * y * (4 * zz - xx - yy),
            C3[3] * z * (2 * zz - 3 * xx - 3 * yy),
            C3[4] * x * (4 * zz - xx - yy),
            C3[5] * z * (xx - yy),
            C3[6] * x * (xx - 3 * yy),
        ]
    return np.stack(cols, axis=1)


def sh_to_rgb(sh_dc: np.ndarray, sh_rest: np.ndarray, dirs: np.ndarray, degree: int) -> np.ndarray:
    """View-dependent colour before the clamp: C0*dc + bands 1..degree + 0.5.

    dirs are unit vectors from the camera to each centre, in the object's local frame.
    """
    basis = sh_basis(dirs, degree)
    rgb = basis[:, :1] * sh_dc + 0.5
    k = (degree + 1) ** 2 - 1
    if k:
        rgb = rgb + np.einsum("nk,nkc->nc", basis[:, 1:], sh_rest[:, :k])
    return rgb
