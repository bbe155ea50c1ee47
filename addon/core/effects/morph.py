"""Morph to target: blend every splat towards a partner in another splat set.

The target must already be in the source object's space (the Blender layer maps it with the
two objects' world matrices). Pairing (`pair`): by index when the counts match; otherwise a
spatial-sort pairing: both sets are ordered along a 30-bit Morton curve over their joint
bounding box, and the k-th splat of the smaller set pairs with the splat at rank
floor((k + 0.5) * n_large / n_small) of the larger. Splats of the larger set left without a
partner fade: unpaired source splats fade out, unpaired target splats fade in, each in
place. The output is in the larger set's order (`aligned`). At amount 0 the result is the
source itself, at amount 1 the target itself. Position, scale, opacity and SH are blended
linearly, rotation by slerp (shortest arc).
"""
from __future__ import annotations

import threading
from dataclasses import dataclass, replace

import numpy as np

from ..reframe import map_into
from ..splats import ARRAYS, SplatSet, sh_coeff_count
from .array_memo import ArrayMemo
from .common import F32, EffectParams, for_blocks, split
from .kind import EffectKind, Field, GpuPath
from .recycle import BUFFERS


@dataclass
class Pairing:
    source: np.ndarray        # indices into the source, paired element-wise with `target`
    target: np.ndarray
    source_only: np.ndarray   # unpaired source indices (fade out)
    target_only: np.ndarray   # unpaired target indices (fade in)
    in_order: bool = False    # source and target are every index in order (equal counts)


@dataclass
class Morph(EffectParams):
    target: SplatSet | None = None
    pairing: Pairing | None = None   # optional precomputed pair(source, target)


def morton_order(positions: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    span = np.maximum(high - low, 1e-12)
    cells = ((positions - low) / span * 1023.0).clip(0, 1023).astype(np.uint64)
    code = np.zeros(positions.shape[0], np.uint64)
    for bit in range(10):
        for axis in range(3):
            code |= ((cells[:, axis] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(3 * bit + axis)
    return np.argsort(code, kind="stable")


def pair(source: np.ndarray, target: np.ndarray) -> Pairing:
    n, m = source.shape[0], target.shape[0]
    empty = np.zeros(0, np.int64)
    if n == m:
        every = np.arange(n)
        return Pairing(every, every, empty, empty, in_order=True)
    if n == 0 or m == 0:
        return Pairing(empty, empty, np.arange(n), np.arange(m))
    both = np.concatenate([source, target]).astype(np.float64)
    low, high = both.min(axis=0), both.max(axis=0)
    src_order, tgt_order = morton_order(source, low, high), morton_order(target, low, high)
    small, large = (src_order, tgt_order) if n < m else (tgt_order, src_order)
    ranks = ((np.arange(len(small)) + 0.5) * len(large) / len(small)).astype(np.int64)
    leftover = np.ones(len(large), bool)
    leftover[ranks] = False
    if n < m:
        return Pairing(small, large[ranks], empty, np.sort(large[leftover]))
    return Pairing(large[ranks], small, np.sort(large[leftover]), empty)


LERP_BYTES = 3 << 19   # bytes of a lerp block: 8192 rows of degree-3 sh_rest


def _lerp(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    """a + (b - a) t into one new array, a block of rows at a time so the intermediate
    stays in cache: memory traffic is one read of a and b and one write (sh_rest, 180 MB
    per million degree-3 splats, is most of a morph's bytes). Blocks are LERP_BYTES, not a
    row count, so a narrow array (positions) is not cut into a hundred blocks of call
    overhead; smaller blocks that fit the 1 MB L2 measured slower. Blocks run on two threads
    (for_blocks): with its output in a recycled buffer (recycle.py: no first-touch page
    zeroing) the lerp is bound by each core's own bandwidth and two threads halve its wall
    time for +9% CPU (on fresh pages: -30% wall time for +36% CPU)."""
    out = BUFFERS.empty(a.shape, a.dtype)
    scale = F32(t)

    def block(part):
        rows_out, first = out[part], a[part]
        np.subtract(b[part], first, out=rows_out)
        rows_out *= scale
        rows_out += first

    for_blocks(a.shape[0], block, max(1, LERP_BYTES // max(1, a[:1].nbytes)))
    return out


def morph_positions(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    """blend's centres for pairs in order: what a renderer that blends the rest itself
    sorts and draws by."""
    return _lerp(a, b, t)


@dataclass
class SlerpSetup:
    """What slerp computes from the two rotation sets alone, not from t."""
    a: list          # q0's four contiguous columns
    b: list          # q1's, turned onto q0's hemisphere (times the sign of q0.q1: exact)
    theta: np.ndarray
    sin: np.ndarray  # sin(theta), 1 where the pair nearly coincides
    near: np.ndarray # indices of those pairs (nlerp weights), ascending


def _dot(a: list, b: list) -> np.ndarray:
    dot = a[0] * b[0]
    for i in range(1, 4):
        dot += a[i] * b[i]
    return dot


def arc_signs(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """(N,) float32 +-1: the sign slerp turns q1 by, onto q0's hemisphere (the shortest arc).
    Where q0.q1 is near 0 either arc is as short, and the sign is this rounding's: a renderer
    that slerps rounded quaternions takes it from here to turn the same way."""
    return np.copysign(F32(1.0), _dot(split(q0), split(q1)))


def slerp_setup(q0: np.ndarray, q1: np.ndarray) -> SlerpSetup:
    a, b = split(q0), split(q1)
    dot = _dot(a, b)
    sign = np.copysign(F32(1.0), dot)
    for col in b:
        col *= sign  # b (w1 sign) = (b sign) w1 bit for bit: a product's sign is its own
    np.abs(dot, out=dot)
    np.minimum(dot, F32(1.0), out=dot)
    theta = np.arccos(dot)
    sin = np.sin(theta)
    near = sin < 1e-5
    sin[near] = 1.0
    setup = SlerpSetup(a, b, theta, sin, np.flatnonzero(near))
    for array in (*a, *b, theta, sin, setup.near):
        array.flags.writeable = False
    return setup


def slerp(q0: np.ndarray, q1: np.ndarray, t: float) -> np.ndarray:
    """Shortest-arc slerp of (N, 4) quaternions; nlerp where they nearly coincide
    (sin(theta) < 1e-5), where slerp's weights lose precision. The parts that do not
    depend on t are memoized per pair of arrays (SLERPS), so scrubbing a morph between
    the same two sets computes only the weights and the blend."""
    setup = SLERPS.get(q0, q1)
    out = np.empty((q0.shape[0], 4), F32)
    for_blocks(q0.shape[0], lambda part: _slerp_block(setup, t, part, out))
    return out


def _slerp_block(setup: SlerpSetup, t: float, part: slice, out: np.ndarray) -> None:
    """The reference slerp's float32 operations on rows `part`, with fewer temporaries."""
    theta, sin = setup.theta[part], setup.sin[part]
    w0 = np.multiply(theta, F32(1.0 - t))
    np.sin(w0, out=w0)
    w0 /= sin
    w1 = np.multiply(theta, F32(t))
    np.sin(w1, out=w1)
    w1 /= sin
    low, high = np.searchsorted(setup.near, (part.start, part.stop))
    if high > low:
        near = setup.near[low:high] - part.start
        w0[near] = 1.0 - t
        w1[near] = t
    cols, term, norm = [], np.empty_like(w0), None
    for qa, qb in zip(setup.a, setup.b):
        col = qa[part] * w0
        np.multiply(qb[part], w1, out=term)
        col += term
        if norm is None:
            norm = col * col  # = 0 + col * col, the reference's first sum: squares are >= +0
        else:
            np.multiply(col, col, out=term)
            norm += term
        cols.append(col)
    np.sqrt(norm, out=norm)
    np.maximum(norm, F32(1e-12), out=norm)
    np.divide(F32(1.0), norm, out=norm)
    for i, col in enumerate(cols):
        np.multiply(col, norm, out=out[part, i])


class SlerpCache:
    """slerp_setup of pairs of rotation arrays, keyed by the arrays themselves."""

    def __init__(self, size: int = 2):
        self.memo = ArrayMemo(size)

    def get(self, q0: np.ndarray, q1: np.ndarray) -> SlerpSetup:
        return self.memo.get((q0, q1), (), lambda: slerp_setup(q0, q1))

    def clear(self) -> None:
        self.memo.clear()


SLERPS = SlerpCache()


@dataclass(frozen=True)
class Ends:
    """A morph's two ends splat for splat: output splat i blends source[i] into target[i]."""
    source: SplatSet
    target: SplatSet
    pairing: Pairing   # of the ends themselves: in order


def aligned(source: SplatSet, target: SplatSet, pairing: Pairing) -> Ends:
    """The morph's two ends in the larger set's order (the source's on a tie), both at the
    higher SH degree (the lower zero-padded): each splat of the smaller set sits at its
    partner's index, and a splat without a partner has itself, transparent, as its other
    end, so it fades out (a source splat) or in (a target splat) in place. Blending the ends
    in order is the morph; a renderer handed them blends in order too. Memoized by the arrays
    (ALIGNED): scrubbing gathers them once. Keeping the larger set's order keeps a source of
    at least the target's count in its own order, so noise fields after the morph stay on
    its splats (stack.py)."""
    arrays = tuple(getattr(s, f) for s in (source, target) for f in ARRAYS)
    arrays += (pairing.source, pairing.target, pairing.source_only, pairing.target_only)
    new_a, new_b, in_order = ALIGNED.get(arrays, (), lambda: _align(source, target, pairing))
    return Ends(replace(source, **new_a), replace(target, axes=source.axes, **new_b), in_order)


def _align(source: SplatSet, target: SplatSet, pairing: Pairing) -> tuple:
    """aligned's new arrays only ({field: array} for each end, the ends' pairing): a memo
    value that held its inputs' arrays would keep its own weak keys alive."""
    k = sh_coeff_count(max(source.sh_degree, target.sh_degree))
    count = max(source.count, target.count)  # both, paired in order
    if pairing.in_order:
        new_a, new_b = _padded(source, k), _padded(target, k)
    elif source.count >= target.count:
        new_a = _padded(source, k)
        new_b = _placed(count, k, ((target, pairing.target, pairing.source, False),
                                   (source, pairing.source_only, pairing.source_only, True)))
    else:
        new_a = _placed(count, k, ((source, pairing.source, pairing.target, False),
                                   (target, pairing.target_only, pairing.target_only, True)))
        new_b = _padded(target, k)
    every = np.arange(count)
    for array in (*new_a.values(), *new_b.values(), every):
        array.flags.writeable = False
    return new_a, new_b, Pairing(every, every, every[:0], every[:0], in_order=True)


def _padded(s: SplatSet, k: int) -> dict:
    if s.sh_rest.shape[1] == k:
        return {}
    rest = np.zeros((s.count, k, 3), F32)
    rest[:, :s.sh_rest.shape[1]] = s.sh_rest
    return {"sh_rest": rest}


def _placed(count: int, k: int, parts) -> dict:
    """count new splats' arrays, filled by parts (set, its rows, the rows they go to, whether
    they go transparent): between them the parts cover every row."""
    out = {"positions": np.empty((count, 3), F32), "scales": np.empty((count, 3), F32),
           "rotations": np.empty((count, 4), F32), "opacities": np.empty(count, F32),
           "sh_dc": np.empty((count, 3), F32), "sh_rest": BUFFERS.empty((count, k, 3), F32)}
    for s, rows, to, transparent in parts:
        for f in ("positions", "scales", "rotations", "opacities", "sh_dc"):
            out[f][to] = getattr(s, f)[rows]
        width = s.sh_rest.shape[1]
        out["sh_rest"][to, :width] = s.sh_rest[rows]
        if width < k:
            out["sh_rest"][to, width:] = 0.0
        if transparent:
            out["opacities"][to] = 0.0
    return out


ALIGNED = ArrayMemo(2)


def blend(source: SplatSet, target: SplatSet, pairing: Pairing, t: float) -> SplatSet:
    """Every splat blended from its source end to its target end (aligned)."""
    ends = aligned(source, target, pairing)
    a, b = ends.source, ends.target
    return SplatSet(
        positions=_lerp(a.positions, b.positions, t), scales=_lerp(a.scales, b.scales, t),
        rotations=slerp(a.rotations, b.rotations, t), opacities=_lerp(a.opacities, b.opacities, t),
        sh_dc=_lerp(a.sh_dc, b.sh_dc, t), sh_rest=_lerp(a.sh_rest, b.sh_rest, t), axes=source.axes)


def pairing_for(splats: SplatSet, p: Morph) -> Pairing:
    """p's pairing where it pairs these splats with p's target, else theirs made now."""
    pairing = p.pairing
    if (pairing is None or len(pairing.source) + len(pairing.source_only) != splats.count
            or len(pairing.target) + len(pairing.target_only) != p.target.count):
        pairing = pair(splats.positions, p.target.positions)
    return pairing


def apply(splats: SplatSet, p: Morph, time: float = 0.0, rest=None) -> SplatSet:
    if not p.enabled or p.target is None or p.amount <= 0.0:
        return splats
    if p.amount >= 1.0:
        return replace(p.target, axes=splats.axes)
    return blend(splats, p.target, pairing_for(splats, p), p.amount)


class MorphCache:
    """Targets mapped into their source's space, with their pairings, keyed by the data they
    came from (a pure cache: its owner clears it when that data may change)."""

    def __init__(self, size: int = 4):
        self.size = size
        self.entries: dict = {}
        self.lock = threading.Lock()  # the viewport and a render thread may share it

    def target(self, source: SplatSet, source_key, target: SplatSet, target_key, relative):
        """(target mapped by `relative` (4x4 source <- target), pair(source, mapped))."""
        key = (source_key, source.count, target_key, relative.tobytes())
        with self.lock:
            hit = self.entries.get(key)
        if hit is None:
            mapped = map_into(target, relative)
            hit = (mapped, pair(source.positions, mapped.positions))
            with self.lock:
                self.entries[key] = hit
                while len(self.entries) > self.size:
                    self.entries.pop(next(iter(self.entries)))
        return hit

    def clear(self):
        with self.lock:
            self.entries.clear()


def _target(values: dict, fps: float) -> dict:
    target, pairing = values["target"]
    return {"target": target, "pairing": pairing}


KIND = EffectKind(
    "MORPH", 5, "Morph", "Blend towards another splat object", "SHAPEKEY_DATA", Morph, apply,
    gpu=GpuPath("morph"),
    moves_splats=True, depends_on_time=False, fields=(
        Field("target", "SPLATS", "Target", derived=True, description=(
            "Splat object to morph into (its own data, not its effects). To keep it from "
            "showing, untick its Look > Show rather than hiding it, so the render still "
            "evaluates its animation")),),
    derive=_target, opaque=("target", "pairing"))
