"""Effect evaluation cost per frame for 1M splats (degree 3): one row per effect type, one for
a stack of three, medians of several runs, each at a new time (as playback does).
"Cold" rows clear the memoized noise values (new layers, as a jump in time needs); "new
centres" also clears the centres' lattice geometry (new base data, once per edit).

Beside each row: the bytes the kernel must touch (arrays it reads + arrays it writes) and the
time a plain numpy copy of that many bytes takes in the same run (the memory-bandwidth
floor), so the table says how far each effect is from being bandwidth-bound.

    python -m bench.effects_bench [--count N] [--runs R] [--no-bpy] [--no-core]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from addon.core.effects import (Displace, Explode, Grade, Morph, Reveal, Twist, evaluate_stack,
                                pair)
from addon.core.effects import common, noise
from addon.core.effects.lattice import LATTICES
from testing.synth import random_splats
from addon.core.look import CropSphere, apply_crop
from addon.core.splats import SplatSet
from bench.common import wall_and_cpu

FIELDS = ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")


def make_splats(n: int, degree: int, seed: int) -> SplatSet:
    return random_splats(n, degree, seed, box=True, log_scale=(np.log(0.005), np.log(0.05)),
                         opacity=(0.1, 1.0), dc=0.5, rest=0.05)


def measure(fn, runs: int) -> tuple[float, float]:
    """(wall ms, CPU ms) medians of fn(i). CPU time counts both threads of the block
    loops (common.for_blocks), so it is at least the one-thread cost; wall time is what
    the drawing thread waits, less than CPU on two free cores, more while they are shared."""
    wall, cpu = wall_and_cpu(fn, runs)
    return wall * 1e3, cpu * 1e3


def touched_bytes(before: SplatSet, after: SplatSet) -> int:
    """Bytes written (changed arrays) + read (positions for any field, changed arrays' inputs)."""
    written = sum(getattr(after, f).nbytes for f in FIELDS if getattr(after, f) is not getattr(before, f))
    read = before.positions.nbytes + written
    return read + written


def copy_fn(nbytes: int):
    """Bandwidth floor: a plain numpy copy moving nbytes (half read, half written)."""
    src = np.ones(max(1, nbytes // 8), np.float32)
    dst = np.empty_like(src)
    return lambda _i: np.copyto(dst, src)


def rows(source: SplatSet, target: SplatSet):
    pairing = pair(source.positions, target.positions)
    fewer = target.subset(np.arange(3 * target.count // 4))
    return [
        ("reveal (plane, glow)", [Reveal(progress=0.0, width=0.3, glow_strength=1.0)]),
        ("reveal (noise, warm)", [Reveal(shape="NOISE", progress=0.5, width=0.2)]),
        ("reveal (noise, cold)", [Reveal(shape="NOISE", progress=0.5, width=0.2)], "cold"),
        ("displace (warm: noise layers memoized)", [Displace(amplitude=0.1, frequency=2.0)]),
        ("displace (cold: two new layers)", [Displace(amplitude=0.1, frequency=2.0)], "cold"),
        ("displace (new centres: lattice too)", [Displace(amplitude=0.1, frequency=2.0)], "new"),
        ("twist then displace (warm)", [Twist(twist=0.5), Displace(amplitude=0.1, frequency=2.0)]),
        ("explode (spin, fade)", [Explode(spin=2.0, gravity=1.0, fade=0.3)]),
        ("explode (no spin)", [Explode(gravity=1.0)]),
        ("twist + swirl", [Twist(twist=0.5, swirl=1.0)]),
        ("grade (height)", [Grade(field="HEIGHT", low=-2.0, high=2.0)]),
        ("grade (noise, warm)", [Grade(field="NOISE")]),
        ("morph (0.5)", [Morph(target=target, pairing=pairing, amount=0.5)]),
        ("morph (0.5), to 3/4 as many", [Morph(target=fewer, pairing=pair(source.positions, fewer.positions),
                                               amount=0.5)]),
        ("STACK: reveal + displace + grade", [Reveal(progress=0.0, width=0.3, glow_strength=1.0),
                                              Displace(amplitude=0.1, frequency=2.0),
                                              Grade(field="HEIGHT", low=-2.0, high=2.0)]),
        ("STACK: same, cold noise", [Reveal(progress=0.0, width=0.3, glow_strength=1.0),
                                     Displace(amplitude=0.1, frequency=2.0),
                                     Grade(field="HEIGHT", low=-2.0, high=2.0)], "cold"),
        ("STACK: reveal + twist + grade", [Reveal(progress=0.0, width=0.3),
                                           Twist(twist=0.5),
                                           Grade(field="HEIGHT", low=-2.0, high=2.0)]),
    ]


GOALS = (("STACK: reveal + displace + grade", 16.0, "a stack of three"),
         ("STACK: same, cold noise", 33.0, "the stack with cold noise"),
         ("morph (0.5)", 33.0, "morph"))


def core_table(n: int, runs: int) -> None:
    source, target = make_splats(n, 3, 1), make_splats(n, 3, 2)
    print(f"{n:,} splats, degree 3 ({sum(getattr(source, f).nbytes for f in FIELDS) / 1e6:.0f} MB), "
          f"medians of {runs} runs, float32 numpy, blocks on {common.THREADS} thread(s)")
    print(f"{'effect':40s} {'wall ms':>8s} {'CPU ms':>8s} {'MB touched':>11s} {'copy floor ms':>14s} "
          f"{'x floor':>8s}")
    wall, cpu = measure(lambda i: evaluate_stack(source, [], 0.1 * i), runs)
    print(f"{'(no effects)':40s} {wall:8.3f} {cpu:8.3f} {0:11.0f}")
    wall, cpu = measure(lambda i: apply_crop(source, sphere=CropSphere(radius=1.5, softness=0.2)), runs)
    print(f"{'look crop (sphere, soft)':40s} {wall:8.1f} {cpu:8.1f}")
    figures = {}
    for name, stack, *cold in rows(source, target):
        result = evaluate_stack(source, stack, 1.0)
        nbytes = touched_bytes(source, result.splats)

        def frame(i, stack=stack, cold=cold[0] if cold else None):
            if cold:
                noise.FIELDS.clear()
            if cold == "new":
                LATTICES.clear()
            evaluate_stack(source, stack, 1.0 + 0.04 * i)

        wall, cpu = measure(frame, runs)
        floor = measure(copy_fn(nbytes), runs)[1]
        print(f"{name:40s} {wall:8.1f} {cpu:8.1f} {nbytes / 1e6:11.0f} {floor:14.2f} {cpu / floor:8.1f}")
        figures[name] = (wall, cpu)
    for name, goal, what in GOALS:
        wall, cpu = figures[name]
        print(f"goal: {what} <= {goal:.0f} ms a frame: wall {wall:.1f} ms -> "
              f"{'met' if wall <= goal else 'MISSED'}, CPU {cpu:.1f} ms -> "
              f"{'met' if cpu <= goal else 'MISSED'}")
    print("(wall: what the drawing thread waits, with the blocks on two threads; it includes"
          " waiting for a shared core. CPU: both threads' time, the cost on one core.)")


# The stack of three the Blender rows (here and bench.handoff_bench) measure.
STACK = (("REVEAL", {"edge_width": 0.3, "glow_strength": 1.0}),
         ("DISPLACE", {"amplitude": 0.1, "frequency": 2.0}),
         ("GRADE", {"range_low": -2.0, "range_high": 2.0}))


def add_effects(obj, stack) -> list:
    """Effects on a splat object, as [(type, {property: value})] says; returns them."""
    effects = []
    for kind, values in stack:
        effect = obj.splatline.effects.add()
        effect.type = kind
        for key, value in values.items():
            setattr(effect, key, value)
        effects.append(effect)
    return effects


def bpy_table(n: int, runs: int) -> None:
    """The same stack through Blender: collect_items on a 1M-splat PointCloud object."""
    try:
        import bpy
    except ImportError:
        print("(bpy not importable: Blender rows skipped)")
        return
    from addon import register
    from addon.blender.evaluate import items as evaluate
    from addon.blender.data.pointcloud import new_pointcloud_object

    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy.types.Object, "splatline"):
        register()
    obj = new_pointcloud_object("bench", make_splats(n, 3, 1))
    scene = bpy.context.scene

    def collect(frame, defer=None):
        scene.frame_set(frame)
        return evaluate.collect_items(bpy.context.evaluated_depsgraph_get(), defer)

    t = time.perf_counter()
    collect(1)
    first = (time.perf_counter() - t) * 1e3
    plain = measure(lambda i: collect(2 + i), runs)
    effects = add_effects(obj, STACK)
    effects[-1].keyframe_insert("amount", frame=1)
    obj.update_tag()
    collect(1)
    stacked = measure(lambda i: collect(20 + i), runs)
    print(f"\nThrough Blender (frame_set + collect_items, {n:,} splats):")
    print(f"  first evaluation (reads the PointCloud): {first:8.0f} ms")
    print(f"  later frames, no effects (cached base):  {plain[0]:8.1f} ms wall {plain[1]:8.1f} ms CPU")
    print(f"  later frames, stack of three:            {stacked[0]:8.1f} ms wall {stacked[1]:8.1f} ms CPU")
    scrub_table(collect, runs)
    morph_scrub(obj, n, collect, runs, effects)


def morph_scrub(obj, n: int, collect, runs: int, stack) -> None:
    """A scrubbed frame of a morph alone (the stack disabled) towards another 1M-splat
    object, its amount keyframed, evaluation to upload on the drawing thread: blended in
    the preprocess pass as the viewport does, then the kernel's blend uploaded whole; the
    same towards a 750k-splat object, and after a reveal (on the CPU)."""
    import gpu

    from addon.blender.data.pointcloud import new_pointcloud_object
    from addon.blender.viewport.effect_rows import on_gpu
    from bench.viewport_bench import HEIGHT, WIDTH

    target = new_pointcloud_object("morph target", make_splats(n, 3, 2))
    target.splatline.look.visible = False
    for effect in stack:
        effect.enabled = False
    morph = add_effects(obj, (("MORPH", {}),))[0]
    morph.target = target
    for frame, amount in ((1, 0.0), (100, 1.0)):
        morph.amount = amount
        morph.keyframe_insert("amount", frame=frame)
    off = gpu.types.GPUOffScreen(WIDTH, HEIGHT, format="RGBA16F")
    wall = _scrub_row(off, lambda frame: collect(frame, on_gpu), runs, "morph, worker sort", True)
    print(f"goal: morph, a scrubbed frame from evaluation to upload, <= 33 ms on the drawing thread:"
          f" {wall:.1f} ms -> {'met' if wall <= 33.0 else 'MISSED'}")
    _scrub_row(off, lambda frame: collect(frame, None), runs, "morph on the CPU, worker", True)
    # two captures rarely hold as many splats: a target of 3/4 the count, paired along the
    # Morton curve (the viewport draws the two ends morph.aligned gathers once)
    fewer = new_pointcloud_object("fewer", make_splats(3 * n // 4, 3, 3))
    fewer.splatline.look.visible = False
    morph.target = fewer
    wall = _scrub_row(off, lambda frame: collect(frame, on_gpu), runs, "to 3/4 as many, worker", True)
    print(f"goal: morph to 3/4 as many splats, as above, <= 33 ms: {wall:.1f} ms -> "
          f"{'met' if wall <= 33.0 else 'MISSED'}")
    _scrub_row(off, lambda frame: collect(frame, None), runs, "3/4, on the CPU, worker", True)
    # after an active effect its ends would be gathered every frame: the viewport leaves
    # such a morph on the CPU (deferral._ends_kept); the same frames either way
    stack[0].enabled = True
    _scrub_row(off, lambda frame: collect(frame, on_gpu), runs, "reveal, then to 3/4", True)
    stack[0].enabled = False
    off.free()


def scrub_table(collect, runs: int) -> None:
    """A scrubbed frame on the drawing thread, from evaluation to upload: collect_items,
    then the viewport's prepare (staging, texture uploads, order) into a GPUOffScreen,
    the draw call itself left out (on llvmpipe it is software rasterisation). The draw
    handler's mode sorts on the worker thread (the last order drawn meanwhile), frames
    33 ms apart as playback would leave it; inline sorts it on the drawing thread. Both
    leave the whole stack to the preprocess pass, as the viewport does (the CPU displaces
    the centres it sorts by; the pass adds the noise layers to its rest centres itself);
    'displace on the CPU' leaves it the colour effects alone and uploads the displaced
    centres (the viewport until the displace was deferred); 'all on the CPU' evaluates the
    whole stack on the CPU and uploads its splats (what a final render evaluates)."""
    import gpu

    from bench.viewport_bench import HEIGHT, WIDTH
    from testing.headless import ensure_gpu

    from addon.blender.viewport.effect_rows import on_gpu

    def colour_only(p):
        return type(p) is not Displace and on_gpu(p)

    ensure_gpu()
    print("\nScrubbing through Blender, the stack of three: collect_items + viewport prepare (upload)")
    off = gpu.types.GPUOffScreen(WIDTH, HEIGHT, format="RGBA16F")
    modes = (("draw handler (worker sort)", True, on_gpu, 16.0),
             ("inline sort", False, on_gpu, None),
             ("cold noise, worker sort", True, on_gpu, 33.0),
             ("displace on the CPU, worker", True, colour_only, None),
             ("cold, displace on the CPU", True, colour_only, None),
             ("all on the CPU, worker", True, None, None))
    for label, background, defer, goal in modes:
        def scrub(frame, defer=defer, cold="cold" in label):
            if cold:  # displace's noise layers made afresh each frame
                noise.FIELDS.clear()
            return collect(frame, defer)

        wall = _scrub_row(off, scrub, runs, label, background)
        if goal is not None:
            print(f"goal: {label.split(',')[0]}, a scrubbed frame from evaluation to upload, <= {goal:.0f} ms"
                  f" on the drawing thread: {wall:.1f} ms -> {'met' if wall <= goal else 'MISSED'}")
    off.free()


def _scrub_row(off, collect, runs: int, label: str, background: bool) -> float:
    """One row of scrub_table; returns the median wall ms."""
    from addon.blender.viewport import DrawSettings, ViewportRenderer
    from bench.viewport_bench import HEIGHT, WIDTH, _projection, _view

    renderer = ViewportRenderer(worker=background)
    settings = DrawSettings(sync_sort=not background)
    parts = []

    def frame(i):
        t = time.perf_counter()
        items = collect(40 + i)
        t_eval = time.perf_counter()
        renderer.prepare(items, _view(0), _projection(), (WIDTH, HEIGHT), settings)
        done = time.perf_counter()
        parts.append((t_eval - t, done - t_eval, done - t))
        if background:
            time.sleep(0.033)

    with off.bind():
        frame(-1)  # the first upload and shader build
        parts.clear()
        cpu = measure(frame, runs)[1]
    renderer.close()
    evaluation, prepare, wall = (1e3 * float(np.median(c)) for c in zip(*parts))
    print(f"  {label:28s} {wall:6.1f} ms wall (evaluation {evaluation:5.1f}, upload {prepare:5.1f}),"
          f" {cpu:6.1f} ms CPU of all threads (the worker's sort too)")
    return wall


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--count", type=int, default=1_000_000)
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--no-bpy", action="store_true")
    parser.add_argument("--no-core", action="store_true", help="only the Blender tables")
    args = parser.parse_args(argv if argv is not None else [])
    if not args.no_core:
        core_table(args.count, args.runs)
    if not args.no_bpy:
        bpy_table(args.count, args.runs)
    print("\nWhat limits it: every kernel reads its inputs and writes fresh output arrays (copy-on-"
          "write), so the floor is memory traffic ('copy floor': a numpy copy of the same bytes);"
          " 'x floor' is the CPU time over that. Plane/height fields of the stack's input are"
          " measured once (field_memo) and colour is a few passes over columns; noise costs one"
          " 32-byte gather + an 8-term weighted sum per channel per splat when a layer is new"
          " (cold; the centres' lattice cells and weights are memoized, lattice.py), and a blend"
          " when it is memoized (warm); rotations (spin, twist) and morph's slerp weights are"
          " transcendental-bound (sin, cos per splat; slerp's angles are memoized per pair);"
          " morph's lerp of sh_rest (180 MB) is bandwidth-bound: one read of each input and a"
          " write into a recycled buffer (recycle.py; fresh pages cost the system's zeroing"
          " on first touch, 13 ms per 180 MB). Block loops run on two threads:"
          " wall < CPU on two free cores, wall > CPU while the cores are shared.")


if __name__ == "__main__":
    import sys

    main(sys.argv[1:])
