"""DynamicCapture: a 4D Gaussian splat capture (splats that move, turn and fade in time).

Every representation Splatline reads becomes one of three time models, all evaluated by
`at(t)` (evaluate.py, float32) and `reference_at` (reference.py, float64, formula by formula):

- "spacetime": Spacetime Gaussians (lite) and .splatv. Delta = t - t_center;
  centre = positions + m1 Delta + m2 Delta^2 + m3 Delta^3 (motion (N, 3, 3));
  rotation = normalise(rotations + omega Delta); opacity = opacities exp(-(Delta / t_scale)^2).
- "linear": the same with motion (N, 1, 3) and no omega (FreeTimeGS-style PLY).
- "4dgs": Avala AI's .4dgs model. centre = positions + motion (t - t_center);
  marginal = exp(-1/2 ((t - t_center) / t_scale)^2), 1 where t_scale is +inf;
  visible where window[0] <= t < window[1] and marginal >= cutoff; opacity = opacities marginal;
  rotation = rotations (fixed).

In every model a splat whose opacity at t is below ALPHA_MIN (1/255) is left out, and so is a
splat whose rotation at t is the zero quaternion (counted in Frame.zero_rotations).

Stable indices: the capture's splats never change order. `at(t)` returns a Frame holding the
kept splats as a SplatSet plus `index`, their indices into the capture, so a caller keeps
per-splat state (noise seeds, rest centres) by index: `capture.rest_positions[frame.index]`
is each kept splat's rest centre, its centre at Delta = 0 (its own time centre), which does
not depend on t.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..splats import AXES, AXES_RDF, SplatSet, sh_degree_for
from . import evaluate
from .frame import ALPHA_MIN, Frame  # noqa: F401  (re-exported)

MODELS = ("spacetime", "linear", "4dgs")
UNITS = ("segment", "seconds")
FOURDGS_CUTOFF = 0.05    # the .4dgs marginal visibility threshold (fourdgs DEFAULT_CUTOFF)

# per-splat arrays and their trailing shapes (None: the array may be absent)
_SHAPES = {
    "positions": (3,), "rotations": (4,), "scales": (3,), "opacities": (), "sh_dc": (3,),
    "t_center": (), "t_scale": (),
}


@dataclass
class DynamicCapture:
    """N dynamic splats in one time model; per-splat arrays are float32, activations applied.

    positions   (N, 3)     centre at Delta = 0 (the rest centre)
    motion      (N, D, 3)  polynomial motion: term d multiplies Delta^(d+1); D = 3 spacetime, 1 otherwise
                           (stored as D contiguous planes: motion_planes)
    rotations   (N, 4)     w, x, y, z; spacetime/linear: as stored (normalised after adding omega Delta)
    omega       (N, 4)     angular term (spacetime), or None (zero)
    scales      (N, 3)     linear scales
    opacities   (N,)       base opacity after the sigmoid
    sh_dc, sh_rest         SH as in SplatSet (Spacetime's plain RGB is stored as (rgb - 0.5) / C0)
    t_center    (N,)       time centre (trbf_center, mu_t), in `unit`
    t_scale     (N,)       temporal width: spacetime/linear exp(trbf_scale); 4dgs sigma_t (+inf: never fades)
    window      (N, 2) float64 [lo, hi) validity window (4dgs), or None (always valid)
    segment_offsets (S+1,) int64: segment k's splats are [offsets[k], offsets[k+1])
    t_start, t_end  the capture's time range in `unit`; N segments span [0, N)
    unit        "segment" (Spacetime's t in [0, 1] per segment) or "seconds"
    fps, duration, start   what the file says (None where it says nothing)
    dropped     splats the reader left out, by reason (NaN time fields, zero rotations...)
    """

    model: str
    positions: np.ndarray
    motion: np.ndarray
    rotations: np.ndarray
    omega: np.ndarray | None
    scales: np.ndarray
    opacities: np.ndarray
    sh_dc: np.ndarray
    sh_rest: np.ndarray
    t_center: np.ndarray
    t_scale: np.ndarray
    window: np.ndarray | None = None
    cutoff: float | None = None
    axes: str = AXES_RDF
    t_start: float = 0.0
    t_end: float = 1.0
    unit: str = "segment"
    fps: float | None = None
    duration: float | None = None
    start: float | None = None
    segment_offsets: np.ndarray | None = None
    dropped: dict = field(default_factory=dict)
    source: str | None = None  # the reader's name for what it read ("spacetime-lite PLY", ...)

    def __post_init__(self):
        self.motion = motion_planes(self.motion)
        if self.segment_offsets is None:
            self.segment_offsets = np.array([0, self.count], np.int64)
        self._inv_scale = None  # the fast path's 1 / t_scale, made on first use

    @property
    def count(self) -> int:
        return int(self.positions.shape[0])

    @property
    def segments(self) -> int:
        return int(self.segment_offsets.shape[0] - 1)

    @property
    def sh_degree(self) -> int:
        return sh_degree_for(self.sh_rest.shape[1])

    @property
    def nbytes(self) -> int:
        arrays = (self.positions, self.motion, self.rotations, self.omega, self.scales,
                  self.opacities, self.sh_dc, self.sh_rest, self.t_center, self.t_scale,
                  self.window, self.segment_offsets)
        return int(sum(a.nbytes for a in arrays if a is not None))

    @property
    def rest_positions(self) -> np.ndarray:
        """(N, 3) each splat's centre at Delta = 0: fixed in time, indexed like the capture."""
        return self.positions

    def rest(self) -> SplatSet:
        """Every splat at its rest pose (Delta = 0, base opacity), in capture order."""
        return evaluate.rest_set(self)

    def at(self, t: float) -> Frame:
        """The splats alive at capture time t (float32 fast path, evaluate.py)."""
        return evaluate.evaluate(self, float(t))

    def alive_mask(self, t: float) -> np.ndarray:
        """(N,) bool: which splats `at(t)` keeps (before the zero-rotation check)."""
        return evaluate.alive_mask(self, float(t))

    def segment_at(self, t: float) -> tuple[int, float]:
        """(segment k, time within it) for capture time t. One segment: (0, t), unclamped.
        N segments (segment units, range [0, N)): k = floor(t) clamped to 0..N-1, t - k."""
        if self.segments == 1:
            return 0, t
        k = int(min(max(np.floor(t), 0), self.segments - 1))
        return k, t - k

    def inverse_scale(self) -> np.ndarray:
        """1 / t_scale in float32 (inf where t_scale is 0), computed once."""
        if self._inv_scale is None:
            with np.errstate(divide="ignore"):
                self._inv_scale = (1.0 / self.t_scale.astype(np.float64)).astype(np.float32)
        return self._inv_scale

    def segment_view(self, name: str, a: int, b: int) -> np.ndarray:
        """A read-only view of field `name` over splats a..b, the same array object each
        time: where every splat is kept, the fields time does not change are handed over as
        these, so a renderer that keeps uploads by array identity uploads them once."""
        views = self.__dict__.setdefault("_views", {})
        view = views.get((name, a, b))
        if view is None:
            view = views[(name, a, b)] = getattr(self, name)[a:b].view()
            view.flags.writeable = False
        return view

    def check(self) -> "DynamicCapture":
        """Assert shapes, dtypes and names; returns self."""
        n = self.count
        if self.model not in MODELS:
            raise ValueError(f"DynamicCapture.model {self.model!r} is not one of {MODELS}")
        if self.unit not in UNITS:
            raise ValueError(f"DynamicCapture.unit {self.unit!r} is not one of {UNITS}")
        if self.axes not in AXES:
            raise ValueError(f"DynamicCapture.axes {self.axes!r} is not one of {AXES}")
        for name, tail in _SHAPES.items():
            _expect(name, getattr(self, name), (n,) + tail)
        depth = {"spacetime": 3}.get(self.model, 1)
        _expect("motion", self.motion, (n, depth, 3))
        if self.omega is not None:
            _expect("omega", self.omega, (n, 4))
        if self.window is not None:
            _expect("window", self.window, (n, 2), np.float64)
        rest = self.sh_rest
        if rest.ndim != 3 or rest.shape[0] != n or rest.shape[2] != 3 or rest.dtype != np.float32:
            raise ValueError(f"DynamicCapture.sh_rest: {rest.shape} {rest.dtype}, expected (N, K, 3) float32")
        offsets = self.segment_offsets
        if offsets[0] != 0 or offsets[-1] != n or np.any(np.diff(offsets) < 0):
            raise ValueError(f"DynamicCapture.segment_offsets {offsets} do not split {n} splats")
        return self


def motion_planes(motion: np.ndarray) -> np.ndarray:
    """motion (N, D, 3) laid out as D contiguous (N, 3) planes (a transposed view), so the
    fast path's motion[:, d] is one contiguous array. The values and shape are unchanged."""
    planes = motion.transpose(1, 0, 2)
    if planes.flags.c_contiguous:
        return motion
    return np.ascontiguousarray(planes).transpose(1, 0, 2)


def _expect(name, arr, shape, dtype=np.float32) -> None:
    if arr.shape != shape or arr.dtype != dtype:
        raise ValueError(f"DynamicCapture.{name}: {arr.shape} {arr.dtype}, expected {shape} {np.dtype(dtype)}")
