"""Dynamic captures: evaluating 1M Spacetime splats at one time (DynamicCapture.at) against
np.argsort of 1M float32 depths in the same run (what a frame's sort costs anyway).

    python -m bench dynamic

Rows (medians over TIMES, RUNS passes each):
- argsort 1M float32: the baseline
- at(t) spacetime lite: cubic motion, omega, degree 0 (what Spacetime lite files hold)
- at(t) linear degree 3: linear motion, no omega, 45 higher-SH floats gathered per kept splat
- reference_at (float64) on SUBSET splats, per splat scaled to 1M
Then the memory a splat takes in each capture (DynamicCapture.nbytes / count).
Then .4dgs: the linear degree-3 capture (in seconds) written by Splatline, and that file read
by Splatline (read_dynamic) and by fourdgs.read (the format's reference reader, when it is
installed) in the same run: median of RUNS reads, and each reader's peak of traced
(numpy and Python) allocations in a separate read (tracemalloc).
"""
from __future__ import annotations

import os
import statistics
import tempfile
import time
import tracemalloc

import numpy as np

COUNT = 1_000_000
SUBSET = 100_000
TIMES = (0.1, 0.3, 0.5, 0.7, 0.9)
RUNS = 3


def _capture(n: int, model: str, degree: int, seed: int = 0):
    from addon.core.dynamic import DynamicCapture
    rng = np.random.default_rng(seed)
    depth = 3 if model == "spacetime" else 1
    k = (degree + 1) ** 2 - 1
    f32 = np.float32
    return DynamicCapture(
        model=model, positions=rng.normal(0, 1, (n, 3)).astype(f32),
        motion=rng.normal(0, 0.2, (n, depth, 3)).astype(f32),
        rotations=rng.normal(0, 1, (n, 4)).astype(f32),
        omega=rng.normal(0, 0.3, (n, 4)).astype(f32) if model == "spacetime" else None,
        scales=rng.uniform(0.001, 0.05, (n, 3)).astype(f32), opacities=rng.uniform(0.05, 1, n).astype(f32),
        sh_dc=rng.normal(0, 1, (n, 3)).astype(f32), sh_rest=rng.normal(0, 0.1, (n, k, 3)).astype(f32),
        t_center=rng.uniform(0, 1, n).astype(f32), t_scale=np.exp(rng.uniform(-2.5, 0.5, n)).astype(f32)).check()


def _median_ms(fn, args) -> float:
    times = []
    for _ in range(RUNS):
        for a in args:
            t0 = time.perf_counter()
            fn(a)
            times.append(time.perf_counter() - t0)
    return 1000.0 * statistics.median(times)


def main() -> None:
    from addon.core.dynamic import reference_at

    depths = [np.random.default_rng(i).random(COUNT, np.float32) for i in range(len(TIMES))]
    lite, linear = _capture(COUNT, "spacetime", 0), _capture(COUNT, "linear", 3, seed=1)
    small = _capture(SUBSET, "spacetime", 0, seed=2)
    lite.at(0.5), linear.at(0.5)  # warm up (the cached 1 / t_scale)
    base = _median_ms(np.argsort, depths)
    rows = [("argsort 1M float32 (baseline)", base, None)]
    for name, capture in (("at(t) spacetime lite, degree 0", lite), ("at(t) linear, degree 3", linear)):
        ms = _median_ms(capture.at, TIMES)
        alive = statistics.median(capture.at(t).alive for t in TIMES)
        rows.append((f"{name} ({alive / COUNT:.0%} alive)", ms, ms / base))
    ref = _median_ms(lambda t: reference_at(small, t), TIMES) * COUNT / SUBSET
    rows.append((f"reference_at float64 ({SUBSET // 1000}k, scaled to 1M)", ref, ref / base))
    print(f"{'row':<52}{'ms':>10}{'x argsort':>11}")
    for name, ms, ratio in rows:
        print(f"{name:<52}{ms:>10.1f}{'' if ratio is None else f'{ratio:>11.2f}'}")
    print(f"\nmemory per splat: spacetime lite {lite.nbytes / COUNT:.0f} B, linear degree 3 "
          f"{linear.nbytes / COUNT:.0f} B (DynamicCapture.nbytes; the fast path's cached 1/t_scale adds 4 B)")
    fourdgs_rows(linear)


def _peak_mib(fn, arg) -> float:
    tracemalloc.start()
    try:
        fn(arg)
        return tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()


def fourdgs_rows(linear) -> None:
    """Splatline's .4dgs reader against fourdgs.read on one 1M-splat file."""
    from addon.core.dynamic import read_dynamic, to_fourdgs, write_dynamic
    capture = to_fourdgs(linear, seconds_per_unit=1.0)
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "bench.4dgs")
        t0 = time.perf_counter()
        write_dynamic(path, capture)
        print(f"\n.4dgs, {COUNT // 1000}k splats, SH degree 3, {os.path.getsize(path) / 2**20:.1f} MiB "
              f"(Splatline wrote it in {time.perf_counter() - t0:.1f} s)")
        readers = [("Splatline read_dynamic", read_dynamic)]
        try:
            import fourdgs
            readers.append((f"fourdgs {fourdgs.__version__} read", fourdgs.read))
        except ImportError:
            print("fourdgs is not installed (pip install fourdgs==0.6.0): no baseline row")
        print(f"{'reader':<32}{'ms':>10}{'peak MiB':>10}{'x fourdgs':>11}")
        rows = [(name, _median_ms(fn, [path]), _peak_mib(fn, path)) for name, fn in readers]
        base = rows[-1][1] if len(rows) > 1 else None
        for name, ms, peak in rows:
            print(f"{name:<32}{ms:>10.0f}{peak:>10.0f}{'' if base is None else f'{ms / base:>11.2f}'}")


if __name__ == "__main__":
    main()
