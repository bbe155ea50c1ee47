"""The one in-memory splat set that every reader returns and every renderer consumes."""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

# Source axis conventions, named by what +x, +y, +z mean in the file.
AXES_RDF = "RDF"  # right, down, forward: 3DGS / COLMAP / INRIA .ply, .splat
AXES_RUB = "RUB"  # right, up, back: SPZ (OpenGL-like)
AXES_RFU = "RFU"  # right, forward, up: Blender's own frame (no rotation needed)
AXES = (AXES_RDF, AXES_RUB, AXES_RFU)


def sh_coeff_count(degree: int) -> int:
    """Number of higher (non-DC) SH coefficients per channel for a degree."""
    return (degree + 1) ** 2 - 1


# Files (SPZ 3+, Blender 5.3's own splats) may carry degree 4 (24 coefficients); Splatline
# renders up to 3, so readers keep bands 0..3 and report the rest (ReadReport.dropped_sh).
RENDER_MAX_DEGREE = 3
FILE_MAX_DEGREE = 4


def file_sh_degree(rest_count: int) -> int:
    """Degree a file's higher-coefficient count stands for, up to FILE_MAX_DEGREE; ValueError
    otherwise. Unlike sh_degree_for, accepts degrees that SplatSet itself never holds."""
    for degree in range(FILE_MAX_DEGREE + 1):
        if sh_coeff_count(degree) == rest_count:
            return degree
    raise ValueError(f"{rest_count} higher SH coefficients per channel match no degree "
                     f"0..{FILE_MAX_DEGREE}")


def sh_degree_for(rest_count: int) -> int:
    """Degree whose higher-coefficient count is rest_count; ValueError otherwise."""
    for degree in range(4):
        if sh_coeff_count(degree) == rest_count:
            return degree
    raise ValueError(f"{rest_count} higher SH coefficients per channel match no degree 0..3")


# SplatSet's per-splat arrays, in field order (the rest of its fields describe them).
ARRAYS = ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")


@dataclass
class SplatSet:
    """N Gaussians in the file's own frame, with activations already applied.

    positions  (N, 3) float32   centres
    scales     (N, 3) float32   linear scales (exp of the PLY log scale)
    rotations  (N, 4) float32   quaternions w, x, y, z, normalized
    opacities  (N,)   float32   opacity after sigmoid, in [0, 1]
    sh_dc      (N, 3) float32   SH DC coefficients (not colours)
    sh_rest    (N, K, 3) float32 higher SH coefficients, K = (deg+1)^2 - 1, coefficient-major
    axes       source axis convention, one of AXES
    sh_degree_in_file  see below
    antialiased  the capture was trained with anti-aliasing (gsplat's antialiased mode,
               Mip-Splatting): SPZ's header flag 0x1, a PLY's `SplatRenderMode: mip` or
               `antialiased 1` comment; renderers then apply the opacity compensation
               (RenderOptions.antialiased), and writers write the flag back
    """

    positions: np.ndarray
    scales: np.ndarray
    rotations: np.ndarray
    opacities: np.ndarray
    sh_dc: np.ndarray
    sh_rest: np.ndarray
    axes: str = AXES_RDF
    # the SH degree the source held, where a reader kept fewer bands (a degree-4 file read
    # as degree 3, or any file read under a max_degree); None when it kept them all, or the
    # reader does not say. Only read_with_report reads it.
    sh_degree_in_file: int | None = None
    antialiased: bool = False

    @property
    def count(self) -> int:
        return int(self.positions.shape[0])

    @property
    def sh_degree(self) -> int:
        return sh_degree_for(self.sh_rest.shape[1])

    def check(self) -> "SplatSet":
        """Assert the shapes and dtypes above; returns self for chaining."""
        n = self.count
        expect = {
            "positions": (n, 3), "scales": (n, 3), "rotations": (n, 4),
            "opacities": (n,), "sh_dc": (n, 3),
        }
        for name, shape in expect.items():
            arr = getattr(self, name)
            if arr.shape != shape or arr.dtype != np.float32:
                raise ValueError(f"SplatSet.{name}: {arr.shape} {arr.dtype}, expected {shape} float32")
        rest = self.sh_rest
        if rest.ndim != 3 or rest.shape[0] != n or rest.shape[2] != 3 or rest.dtype != np.float32:
            raise ValueError(f"SplatSet.sh_rest: {rest.shape} {rest.dtype}, expected (N, K, 3) float32")
        sh_degree_for(rest.shape[1])
        if self.axes not in AXES:
            raise ValueError(f"SplatSet.axes: {self.axes!r} is not one of {AXES}")
        return self

    def subset(self, index) -> "SplatSet":
        """A new set holding the splats picked by a boolean mask or index array."""
        return replace(
            self,
            positions=self.positions[index], scales=self.scales[index],
            rotations=self.rotations[index], opacities=self.opacities[index],
            sh_dc=self.sh_dc[index], sh_rest=self.sh_rest[index],
        )

    def with_sh_degree(self, degree: int) -> "SplatSet":
        """Drop bands above degree (never adds bands)."""
        keep = sh_coeff_count(min(degree, self.sh_degree))
        return replace(self, sh_rest=np.ascontiguousarray(self.sh_rest[:, :keep]))

    @staticmethod
    def empty(degree: int = 0, axes: str = AXES_RDF) -> "SplatSet":
        return SplatSet.allocate(0, degree, axes)

    @staticmethod
    def allocate(n: int, degree: int = 0, axes: str = AXES_RDF) -> "SplatSet":
        """Zeroed arrays with identity rotations, for readers and generators to fill."""
        rotations = np.zeros((n, 4), np.float32)
        rotations[:, 0] = 1.0
        return SplatSet(
            positions=np.zeros((n, 3), np.float32), scales=np.ones((n, 3), np.float32),
            rotations=rotations, opacities=np.ones(n, np.float32),
            sh_dc=np.zeros((n, 3), np.float32),
            sh_rest=np.zeros((n, sh_coeff_count(degree), 3), np.float32), axes=axes,
        )
