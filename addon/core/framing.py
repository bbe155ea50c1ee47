"""Default cameras for a bare capture: robust bounds, front and side views and an orbit.

A capture's own frame decides what "up" means: the file's up axis (-y for the RDF frame of
3DGS/COLMAP files, +y for RUB, +z for RFU). Its forward is the direction its reference
camera looked (+z in RDF, -z in RUB, +y in RFU); that camera often stood off to the
subject's side (guitar.ply's looks at the guitar's edge) or its back, so "front" is the
subject's own: the front view looks level at the side the capture's flat splats face
(core/facing.py: the side it was photographed from), across the subject's broad face (the
horizontal axis along which the centres spread least) when that is near; a capture
photographed all round faces no side, and front is the broad face seen from the side the
capture's camera stood on (front_direction). The side view stands a quarter turn
counter-clockwise from it (seen from above); `turned` turns any of them (--azimuth).
The capture view looks along the capture's forward, levelled. The orbit starts at the
front view, lifted by ELEVATION_DEG, and turns once about up.

Bounds come from the 2nd and 98th percentiles of the world-space centres, so a few
floaters far from the subject neither shrink it (by pushing the camera away) nor move the
point looked at; the command line's cameras take them over the splats that show
(core/visible_bounds.py), which leaves out the faint halo real captures carry. fill_distance puts the camera where the bounds' projected box spans FILL
of the frame's shorter side (in the widest frame of an orbit); fit_distance is the older,
looser fit of the sphere round the box, which left a compact subject at under half the frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .axes import matrix_for
from .camera import look_at
from .matrix_inverse import inverse4
from .percentile import percentiles

LOW_PERCENTILE, HIGH_PERCENTILE = 2.0, 98.0
MARGIN = 1.15  # the percentile box trims the subject's tips (a guitar's headstock): give them room
ELEVATION_DEG = 20.0  # above the horizon: a look slightly down reads as "in front of it"
FILL = 0.8  # of the frame's shorter side: room round the subject, its trimmed tips inside
MODES = ("orbit", "capture", "front", "side")
ORBIT_SAMPLES = 720  # azimuths the orbit's fit checks (frames fall within 0.25 degrees of one)
ISOTROPIC = 0.95  # horizontal spreads closer than this ratio: no broad face to call front
# A facing (core/facing.py) this long decides the front: a hemisphere seen from one side
# gives 0.5, guitar.ply 0.15, a shell closed all round under 0.01
FACING_SURE = 0.1
FACING_SNAP = 30.0  # degrees: a broad face's axis this near the facing is the front's


# Rows a product takes at once (rows_times): under OpenBLAS's threshold for threading
ROWS_PER_PRODUCT = 2048


def rows_times(rows, matrix) -> np.ndarray:
    """rows @ matrix in float64, a block of rows at a time: the same values bit for bit
    (tests/core/test_import_speed_paths.py), but each block stays under OpenBLAS's size for
    threading, whose idle worker would otherwise spin for about 0.1 s of CPU after every
    call on a million centres. A last block of one row joins the one before it: numpy
    multiplies a single row by another BLAS routine, which can round differently."""
    rows, matrix = np.asarray(rows, np.float64), np.asarray(matrix, np.float64)
    out = np.empty(rows.shape[:1] + matrix.shape[1:], np.float64)
    starts = list(range(0, len(rows), ROWS_PER_PRODUCT))
    if len(starts) > 1 and len(rows) - starts[-1] == 1:
        starts.pop()
    for start, end in zip(starts, starts[1:] + [len(rows)]):
        np.matmul(rows[start:end], matrix, out=out[start:end])
    return out


@dataclass(frozen=True)
class Bounds:
    centre: np.ndarray  # (3,) world
    low: np.ndarray
    high: np.ndarray

    @property
    def radius(self) -> float:
        """Half the diagonal of the percentile box; never zero (a one-point capture)."""
        return max(0.5 * float(np.linalg.norm(self.high - self.low)), 1e-3)

    @property
    def size(self) -> float:
        """The percentile box's diagonal (0 for a one-point capture)."""
        return float(np.linalg.norm(self.high - self.low))


def robust_bounds(points_world, low=LOW_PERCENTILE, high=HIGH_PERCENTILE) -> Bounds:
    """Per-axis percentile box of the finite points, and its middle: np.percentile's values
    (core/percentile.py finds them without partitioning a million centres)."""
    pts = np.asarray(points_world, np.float64).reshape(-1, 3)
    finite = _all_columns(np.isfinite(pts))
    every = bool(finite.all())
    if not every and not finite.any():
        raise ValueError("no finite splat centres to frame")
    columns = [np.ascontiguousarray(pts[:, c]) if every else pts[finite, c] for c in range(3)]
    lo, hi = np.array([percentiles(column, (low, high)) for column in columns]).T
    return Bounds((lo + hi) / 2.0, lo, hi)


def _all_columns(mask) -> np.ndarray:
    """mask.all(axis=1) of an (N, 3) boolean array, a column at a time: numpy's reduction
    along a row of 3 runs a loop per row, several times slower at a million points."""
    return mask[:, 0] & mask[:, 1] & mask[:, 2]


def _in_box(pts, bounds: Bounds) -> np.ndarray:
    """Whether each (N, 3) point lies in the box, bounds included: one (N,) mask built a
    bound at a time (0.3x the time of comparing whole rows, then reducing them)."""
    mask = pts[:, 0] >= bounds.low[0]
    for c in range(3):
        if c:
            mask &= pts[:, c] >= bounds.low[c]
        mask &= pts[:, c] <= bounds.high[c]
    return mask


def capture_axes(axes: str, object_rotation) -> tuple[np.ndarray, np.ndarray]:
    """The capture's (up, forward) in world space, for an object whose matrix takes its
    file frame (convention `axes`) to the world. Blender's (z, y) pulled back into the file
    frame through the axis rotation, then pushed out through the object's own rotation."""
    to_blender = matrix_for(axes)
    file_up, file_forward = to_blender.T @ (0.0, 0.0, 1.0), to_blender.T @ (0.0, 1.0, 0.0)
    rotation = np.asarray(object_rotation, np.float64)[:3, :3]
    up, forward = rotation @ file_up, rotation @ file_forward
    return up / np.linalg.norm(up), forward / np.linalg.norm(forward)


def fit_distance(bounds: Bounds, tan_half_x: float, tan_half_y: float) -> float:
    """Centre-to-camera distance at which the bounds' sphere, MARGIN times larger, fits the
    narrower field (a sphere: the orbit sees the subject from every side)."""
    half = math.atan(min(tan_half_x, tan_half_y))
    return MARGIN * bounds.radius / math.sin(half)


def fit_box_distance(bounds: Bounds, tan_half_x: float, tan_half_y: float) -> float:
    """Distance from the centre at which the box's horizontal diagonal fits the width and
    its height (world z) fits the height of the frame, plus half that diagonal (the near
    side): a tighter fit than fit_distance's sphere, for a view that stays near the side."""
    extent = bounds.high - bounds.low
    width, height = float(np.linalg.norm(extent[:2])), float(extent[2])
    return max(width / 2 / tan_half_x, height / 2 / tan_half_y) + width / 2


def front_direction(points_world, bounds: Bounds, up, forward, facing=None) -> np.ndarray:
    """The level direction the front view looks along. `facing` (core/facing.py: the level
    direction the capture's splats face, as long as it is sure) decides where it is at
    least FACING_SURE: the view looks back against it, along the subject's broad face's
    axis when that is within FACING_SNAP of it. Otherwise: that axis (the eigenvector of
    least spread of the centres inside the bounds, in the plane level with up), signed to
    point the way the capture's camera looked; a subject with no broad face (spreads within
    ISOTROPIC) keeps the capture camera's own direction, levelled."""
    up = np.asarray(up, np.float64)
    ahead = _level(up, forward)
    broad = _broad_face_axis(points_world, bounds, up, ahead)
    sure = facing is not None and float(np.linalg.norm(facing)) >= FACING_SURE
    if not sure:
        return ahead if broad is None else (broad if broad @ ahead >= 0.0 else -broad)
    against = -_level(up, facing)
    if broad is not None and abs(float(broad @ against)) >= math.cos(math.radians(FACING_SNAP)):
        return broad if broad @ against >= 0.0 else -broad
    return against


def _broad_face_axis(points_world, bounds: Bounds, up, ahead):
    """The level axis along which the centres inside the bounds spread least, or None when
    the level spreads are within ISOTROPIC of each other."""
    across = np.cross(up, ahead)
    pts = np.asarray(points_world, np.float64).reshape(-1, 3)
    inside = np.compress(_in_box(pts, bounds), pts, axis=0)  # a copy: shifted in place
    inside -= bounds.centre
    if len(inside) < 3:
        return None
    spread = np.cov(np.stack([rows_times(inside, ahead), rows_times(inside, across)]))
    values, vectors = np.linalg.eigh(spread)
    if values[1] <= 0.0 or math.sqrt(max(values[0], 0.0) / values[1]) > ISOTROPIC:
        return None
    a, b = vectors[:, 0]
    return a * ahead + b * across


def turned(direction, up, degrees: float) -> np.ndarray:
    """A level direction turned `degrees` counter-clockwise about up (seen from above): the
    command line's --azimuth, applied to the front before any view is built from it."""
    up, direction = np.asarray(up, np.float64), _level(up, direction)
    angle = math.radians(degrees)
    return direction * math.cos(angle) + np.cross(up, direction) * math.sin(angle)


def view_azimuth(view: str) -> float:
    """Where a still view stands, turned from the front view about up."""
    return {"capture": 0.0, "front": 0.0, "side": 0.5 * math.pi}[view]


def front_pose(bounds: Bounds, up, forward, distance: float, elevation_deg: float = 0.0,
               azimuth: float = 0.0) -> np.ndarray:
    """Camera-to-world matrix of a still view: the front view (forward from
    front_direction), or one turned by `azimuth` about up (view_azimuth), raised by
    `elevation_deg`."""
    return _pose_at(bounds, up, forward, distance, azimuth, math.radians(elevation_deg))


def orbit_poses(bounds: Bounds, up, forward, distance: float, count: int,
                elevation_deg: float = ELEVATION_DEG) -> list:
    """`count` camera-to-world matrices, one a frame, evenly round a full turn (the turn's
    end is the next loop's start, so a looped render does not repeat a frame). _pose_at's
    poses to rounding, all at once: one each was 25 ms of a command-line import's 120
    frames (tests/core/test_import_speed_paths.py pins them)."""
    azimuths = [2.0 * math.pi * i / count for i in range(count)]
    rotations = view_rotations(up, forward, azimuths, math.radians(elevation_deg))
    poses = np.zeros((count, 4, 4))
    poses[:, :3, :3] = rotations
    poses[:, :3, 3] = np.asarray(bounds.centre, np.float64) + distance * rotations[:, :, 2]
    poses[:, 3, 3] = 1.0
    return list(poses)


def orbit_azimuths() -> np.ndarray:
    return np.linspace(0.0, 2.0 * math.pi, ORBIT_SAMPLES, endpoint=False)


def box_corners(bounds: Bounds) -> np.ndarray:
    """The percentile box's eight corners, (8, 3)."""
    return np.array([[x, y, z] for x in (bounds.low[0], bounds.high[0])
                     for y in (bounds.low[1], bounds.high[1]) for z in (bounds.low[2], bounds.high[2])])


def frame_fill(points, pose, tan_half_x: float, tan_half_y: float) -> float:
    """The larger side of the points' projected bounding rectangle, as a fraction of the
    frame's shorter side, seen from camera-to-world `pose`; inf if one is not in front."""
    local = (np.asarray(points, np.float64) - pose[:3, 3]) @ pose[:3, :3]
    return float(_fill(local[None], tan_half_x, tan_half_y)[0])


def fill_distance(bounds: Bounds, up, forward, tan_half_x: float, tan_half_y: float,
                  fill: float = FILL, elevation_deg: float = ELEVATION_DEG, azimuths=(0.0,)) -> float:
    """Centre-to-camera distance at which the projected percentile box spans `fill` of the
    frame's shorter side in the widest of the views at `azimuths` (a still view: one; an
    orbit: orbit_azimuths()). Found by bisection: the fill shrinks as the camera backs away.
    Never nearer than the box's own corners."""
    corners = box_corners(bounds) - bounds.centre
    # Camera-frame corners at distance 0: the view's rotation does not depend on distance, and
    # backing away by d only moves every corner d further along the camera's -z.
    views = view_rotations(up, forward, azimuths, math.radians(elevation_deg))
    local = np.einsum("pj,vjk->vpk", corners, views)

    def widest(distance):
        return float(_fill(local - (0.0, 0.0, distance), tan_half_x, tan_half_y).max())

    near = 1.001 * max(0.5 * bounds.size, 1e-3)
    if widest(near) <= fill:  # a very wide lens: the closest the camera may stand
        return near
    far = 2.0 * near
    while widest(far) > fill:
        far *= 2.0
    for _ in range(60):
        middle = 0.5 * (near + far)
        near, far = (middle, far) if widest(middle) > fill else (near, middle)
    return far


def _fill(local, tan_half_x, tan_half_y) -> np.ndarray:
    """frame_fill of each view's camera-frame points, local (views, points, 3)."""
    depth = -local[..., 2]  # a Blender camera looks down its -z
    with np.errstate(divide="ignore", invalid="ignore"):
        x, y = local[..., 0] / depth, local[..., 1] / depth
    spans = np.maximum(np.ptp(x, axis=1), np.ptp(y, axis=1)) / (2.0 * min(tan_half_x, tan_half_y))
    return np.where((depth > 0.0).all(axis=1), spans, np.inf)


def _level(up, forward) -> np.ndarray:
    """forward in the horizon plane of up, unit length."""
    up, forward = np.asarray(up, np.float64), np.asarray(forward, np.float64)
    forward = forward - up * float(forward @ up)
    return forward / np.linalg.norm(forward)


def view_rotations(up, forward, azimuths, elevation) -> np.ndarray:
    """(V, 3, 3): the rotation of _pose_at's camera-to-world matrix at each azimuth, all at
    once (a view's turn depends on neither the distance nor the bounds' centre). Columns
    right, true up and back, built as look_at builds them. fill_distance checks 720 azimuths
    for an orbit: one _pose_at each (look_at and two 4x4 inverses) was 0.09 s of CPU of every
    command-line import. Equal to _pose_at's to rounding (tests/core/test_import_speed_paths.py)."""
    up, forward = np.asarray(up, np.float64), _level(up, forward)
    side = np.cross(up, forward)
    azimuths = np.asarray(azimuths, np.float64).reshape(-1, 1)
    back = -(forward * np.cos(azimuths) + side * np.sin(azimuths))
    back = back * math.cos(elevation) + up * math.sin(elevation)
    back /= np.linalg.norm(back, axis=1, keepdims=True)
    right = np.cross(up, back)
    along_up = np.linalg.norm(right, axis=1) < 1e-12  # looking along up: look_at's fallback
    right[along_up] = np.cross((0.0, 1.0, 0.0), back[along_up])
    right /= np.linalg.norm(right, axis=1, keepdims=True)
    return np.stack([right, np.cross(back, right), back], axis=2)


def _pose_at(bounds, up, forward, distance, azimuth, elevation) -> np.ndarray:
    up, forward = np.asarray(up, np.float64), _level(up, forward)
    side = np.cross(up, forward)  # a quarter turn counter-clockwise about up
    back = -(forward * math.cos(azimuth) + side * math.sin(azimuth))
    direction = back * math.cos(elevation) + up * math.sin(elevation)
    eye = bounds.centre + distance * direction
    return inverse4(look_at(eye, bounds.centre, up))  # not LAPACK's: see matrix_inverse.py


def clip_range(bounds: Bounds, distance: float) -> tuple[float, float]:
    """Near and far planes that keep the whole percentile sphere and far floaters."""
    return max(1e-4, 0.01 * bounds.radius), 10.0 * (distance + bounds.radius)
