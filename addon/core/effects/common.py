"""What every effect kernel shares: its common parameters, the gizmo frame, small math.

Kernels take a read-only SplatSet and return a new one that shares every array they did
not change (copy-on-write): a colour-only effect hands back the very same positions array,
so the sort keys of the renderers stay valid.

The gizmo frame is a 4x4 matrix from gizmo-local to splat-object coordinates (the Empty's
matrix relative to the splat object). Fields (height, distance, plane, noise) are measured
in gizmo-local units, so scaling the Empty scales the field; motions (explode, twist) are
rigid in object space, around the gizmo's origin and its normalized axes.
"""
from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from ..matrix_inverse import inverse_or_pinv

F32 = np.float32


@dataclass
class EffectParams:
    enabled: bool = True
    amount: float = 1.0                      # blend: 0 = no effect, 1 = full effect
    frame: np.ndarray = field(default_factory=lambda: np.eye(4))

    @property
    def active(self) -> bool:
        return self.enabled and self.amount > 0.0


def is_identity(m: np.ndarray) -> bool:
    return bool(np.array_equal(m, np.eye(4)))


inverse = inverse_or_pinv  # a gizmo frame's inverse (not np.linalg.inv: see matrix_inverse)


def local_columns(positions: np.ndarray, frame: np.ndarray, axes=(0, 1, 2)) -> list[np.ndarray]:
    """Gizmo-local coordinates of the centres, one contiguous float32 column per axis asked."""
    cols = [positions[:, 0], positions[:, 1], positions[:, 2]]
    if is_identity(frame):
        return [np.ascontiguousarray(cols[a]) for a in axes]
    inv = inverse(frame)
    out = []
    for a in axes:
        row = inv[a]
        acc = cols[0] * F32(row[0])
        acc += cols[1] * F32(row[1])
        acc += cols[2] * F32(row[2])
        acc += F32(row[3])
        out.append(acc)
    return out


def field_values(positions: np.ndarray, frame: np.ndarray, kind: str, noise=None) -> np.ndarray:
    """A scalar field per splat (a fresh float32 array), measured in the field's frame:
    HEIGHT (local z), DISTANCE (from the frame's origin) or NOISE (noise: the memoized
    value noise of these splats, mapped from [-1, 1] to [0, 1])."""
    if kind == "HEIGHT":
        return local_columns(positions, frame, (2,))[0]
    if kind == "NOISE":
        value = noise * F32(0.5)  # a fresh array: the memoized noise is read-only
        value += F32(0.5)
        return value
    if kind != "DISTANCE":
        raise ValueError(f"unknown field {kind!r}")
    x, y, z = local_columns(positions, frame)
    x *= x
    x += y * y
    x += z * z
    return np.sqrt(x, out=x)


BLOCK = 1 << 16  # rows per block: a block's temporaries stay in cache


def blocks(n: int, block: int = BLOCK):
    """Row slices covering 0..n: kernels whose work is per splat run block by block, so
    their many temporaries are cache-resident and reused instead of streamed through RAM."""
    for start in range(0, n, block):
        yield slice(start, min(n, start + block))


def for_blocks(n: int, fn, block: int = BLOCK) -> None:
    """fn(rows) for each block of rows covering 0..n, where no block reads what another
    writes. Where there are several blocks and THREADS is 2, this thread and one helper
    take blocks in turn (numpy's loops release the GIL), so a frame waits about half as
    long on two free cores; each block's arithmetic is the same on either thread, so
    results are identical to running them in order (tests/core/effects/test_effects_fast_paths.py)."""
    parts = list(blocks(n, block))
    if len(parts) < 4 or THREADS < 2 or threading.current_thread().name.startswith(_NAME):
        # (on the helper itself, a nested call runs in order: waiting there would deadlock)
        for part in parts:
            fn(part)
        return
    todo = iter(parts)
    lock = threading.Lock()

    def work():
        while True:
            with lock:
                part = next(todo, None)
            if part is None:
                return
            fn(part)

    helper = _helper().submit(work)
    try:
        work()
    finally:
        helper.result()  # the helper's error, if any; never returns while it still writes


def _helper() -> ThreadPoolExecutor:
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(1, thread_name_prefix=_NAME)
        return _POOL


def stop_helper() -> None:
    """End the helper thread (the extension's unregister: no thread outlives it); the next
    for_blocks starts a new one."""
    global _POOL
    with _POOL_LOCK:
        pool, _POOL = _POOL, None
    if pool is not None:
        pool.shutdown(wait=True)


THREADS = 2 if (os.cpu_count() or 1) > 1 else 1   # 1: every block on the calling thread
_POOL = None
_POOL_LOCK = threading.Lock()
_NAME = "splatline-effects"


def scale_rows(a: np.ndarray, factor: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """a * factor[:, None] for (N, k) a, column by column (into `out` if given): numpy
    broadcasting against a small trailing axis costs ~3x more than the same work on columns."""
    out = np.empty_like(a) if out is None else out
    for i in range(a.shape[1]):
        np.multiply(a[:, i], factor, out=out[:, i])
    return out


def add_rows(a: np.ndarray, values, factor: np.ndarray | None = None,
             out: np.ndarray | None = None) -> np.ndarray:
    """a + factor[:, None] * values[None, :] (values: k constants), column by column
    (into `out` if given)."""
    out = np.empty_like(a) if out is None else out
    for i in range(a.shape[1]):
        if factor is None:
            np.add(a[:, i], F32(values[i]), out=out[:, i])
        else:
            col = factor * F32(values[i])
            np.add(a[:, i], col, out=out[:, i])
    return out


def put_rows(a: np.ndarray, index: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """a[index] = rows for (N, k) a, returning a: rows moved as single k-item records
    (a void view), several times faster than numpy's fancy assignment of rows."""
    if not (a.flags.c_contiguous and rows.flags.c_contiguous and a.dtype == rows.dtype):
        a[index] = rows
        return a
    record = np.dtype((np.void, a.dtype.itemsize * a.shape[1]))
    np.put(a.view(record).reshape(-1), index, rows.view(record).reshape(-1))
    return a


def unit_columns(cols) -> list[np.ndarray]:
    """Normalize three (N,) components in place (zero vectors stay zero)."""
    length = cols[0] * cols[0]
    length += cols[1] * cols[1]
    length += cols[2] * cols[2]
    np.sqrt(length, out=length)
    np.maximum(length, F32(1e-12), out=length)
    np.divide(F32(1.0), length, out=length)
    for c in cols:
        c *= length
    return cols


def frame_origin(frame: np.ndarray) -> np.ndarray:
    return np.asarray(frame, np.float64)[:3, 3].copy()


def frame_axis(frame: np.ndarray, axis: int = 2) -> np.ndarray:
    """Unit direction of a gizmo axis in object space (+z by default)."""
    v = np.asarray(frame, np.float64)[:3, axis]
    n = np.linalg.norm(v)
    return v / n if n > 0 else np.eye(3)[axis]


def smoothstep01(s: np.ndarray) -> np.ndarray:
    """3s^2 - 2s^3 for s already clipped to [0, 1], in place on s."""
    t = s * s
    s *= F32(-2.0)
    s += F32(3.0)
    s *= t
    return s


def split(a: np.ndarray) -> list[np.ndarray]:
    """(N, k) -> k contiguous (N,) columns (one transposing copy; arithmetic on contiguous
    columns is ~3x faster than on the strided columns of an (N, k) array)."""
    return list(np.ascontiguousarray(np.asarray(a).T))


def join(cols) -> np.ndarray:
    """k (N,) columns -> (N, k) float32."""
    return np.stack(cols, axis=1).astype(F32, copy=False)


def rotate_quats_about(axis, cos_half: np.ndarray, sin_half: np.ndarray, q) -> np.ndarray:
    """(cos_half, sin_half * axis) * q for one constant unit axis (3,): the product with a
    pure quaternion of fixed axis is a fixed linear map, so zero axis terms cost nothing."""
    qw, qx, qy, qz = q if isinstance(q, list) else split(q)
    a = [float(v) for v in axis]
    # (0, a) * (qw, v) = (-a.v, qw a + a x v)
    pure = [None, None, None, None]
    terms = (
        (0, ((-a[0], qx), (-a[1], qy), (-a[2], qz))),
        (1, ((a[0], qw), (a[1], qz), (-a[2], qy))),
        (2, ((a[1], qw), (a[2], qx), (-a[0], qz))),
        (3, ((a[2], qw), (a[0], qy), (-a[1], qx))),
    )
    for i, parts in terms:
        acc = None
        for coeff, col in parts:
            if coeff == 0.0:
                continue
            term = col * F32(coeff)
            acc = term if acc is None else np.add(acc, term, out=acc)
        pure[i] = acc
    out = []
    for base, extra in zip((qw, qx, qy, qz), pure):
        col = base * cos_half
        if extra is not None:
            extra *= sin_half
            col += extra
        out.append(col)
    return join(out)


def per_splat_random(n: int, seed: int, salt: int) -> np.ndarray:
    """(3, n) float32 standard normals (three contiguous rows), a pure function of
    (n, seed, salt). Memoized (bounded; the viewport and a render thread may share it)."""
    key = (n, seed, salt)
    with _RANDOM_LOCK:
        hit = _RANDOM_CACHE.get(key)
    if hit is None:
        rng = np.random.default_rng([seed & 0xFFFFFFFF, salt])
        hit = rng.standard_normal((3, n), dtype=np.float32)
        hit.flags.writeable = False
        with _RANDOM_LOCK:
            _RANDOM_CACHE[key] = hit
            while len(_RANDOM_CACHE) > 4:
                _RANDOM_CACHE.pop(next(iter(_RANDOM_CACHE)))
    return hit


# A pure cache (results never depend on it), bounded to a few arrays.
_RANDOM_CACHE: dict = {}
_RANDOM_LOCK = threading.Lock()
