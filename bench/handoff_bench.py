"""What handing Splatline's evaluated splats to Blender's own engines costs per frame
(Blender 5.3+ native splats, evaluate/native_handoff.py), for 1M splats of degree 3 with a
stack of three effects (the effects bench's: reveal, displace, grade), as playback pays it.

Rows, medians of several frames, each at a new frame:
- evaluation alone: frame_set + collect_items on an object Blender does not draw (plain
  points: no handoff), the cost every Blender version pays;
- with the handoff: frame_set on the same splats as a native splat object (evaluation,
  the look folded in, the companion written, the depsgraph updated);
- parts, timed alone: baked_splats, and a full companion write (later frames write only
  the attributes whose arrays changed: here position and radiance:base).
Run: .venv-5.3/bin/python -m bench.handoff_bench [--count N] [--runs R]
"""
from __future__ import annotations

import argparse
import time

from bench.common import wall_and_cpu
from bench.effects_bench import STACK, add_effects, make_splats

def _scene(bpy, n):
    from addon import register
    from addon.blender.data.pointcloud import new_pointcloud_object

    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy.types.Object, "splatline"):
        register()
    obj = new_pointcloud_object("bench", make_splats(n, 3, 1))
    for effect in add_effects(obj, STACK):
        effect.keyframe_insert("amount", frame=1)
    obj.update_tag()
    return obj


def _row(label, wall_cpu):
    print(f"  {label:<44} {wall_cpu[0] * 1e3:8.1f} ms wall {wall_cpu[1] * 1e3:8.1f} ms CPU")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--count", type=int, default=1_000_000)
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args(argv if argv is not None else [])
    try:
        import bpy
    except ImportError:
        print("(bpy not importable: skipped)")
        return
    from addon.blender.data import evaluated_geometry as geometry
    from addon.blender.data import native
    from addon.blender.evaluate.items import collect_items
    from addon.core.fold_look import baked_splats

    if not native.has_native_splats():
        print(f"(Blender {bpy.app.version_string} has no native splats: nothing is handed off)")
        return
    obj = _scene(bpy, args.count)
    scene = bpy.context.scene

    def frames(first):
        def step(i):
            scene.frame_set(first + i)
            return collect_items(bpy.context.evaluated_depsgraph_get())
        return step

    obj.data.type = "POINTS"  # Blender does not draw it: no companion, evaluation alone
    frames(1)(0)
    alone = wall_and_cpu(frames(10), args.runs)
    obj.data.type = native.splat_type()
    scene.frame_set(2)  # installs the companion and writes it once
    assert geometry.companion(obj) is not None, "the handoff did not install"
    handed = wall_and_cpu(lambda i: scene.frame_set(40 + i), args.runs)
    item = collect_items(bpy.context.evaluated_depsgraph_get())[0]
    bake = wall_and_cpu(lambda i: baked_splats(item), args.runs)
    splats = baked_splats(item)
    write = wall_and_cpu(lambda i: geometry.write(geometry.companion(obj), splats), args.runs)
    print(f"\nHandoff to Blender's engines, {args.count:,} splats, degree 3, stack of three "
          f"(bpy {bpy.app.version_string}, medians of {args.runs} frames):")
    _row("frame_set + collect_items, no handoff", alone)
    _row("frame_set with the handoff", handed)
    _row("baked_splats (the look folded in)", bake)
    _row("a full companion write (the first frame)", write)
    print(f"  handoff / evaluation alone: {handed[0] / alone[0]:.2f}x wall, "
          f"{handed[1] / alone[1]:.2f}x CPU")


if __name__ == "__main__":
    import sys

    t0 = time.perf_counter()
    main(sys.argv[1:])
    print(f"({time.perf_counter() - t0:.0f} s)")
