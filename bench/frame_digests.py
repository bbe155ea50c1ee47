"""Digests of evaluated splats and rendered frames, to show a refactor changes nothing.

For guitar.ply and test64.ply (imported with their axes), each effect kind alone on the
capture, with a keyed amount and its own defaults, at frames 1, 5 and 9: a sha256 of
every evaluated SplatSet array and of the offscreen renderer's frame. Run it on two
checkouts and compare the outputs (`diff`); it uses only what every checkout since the
effect table has (import_file, the effect_add operator, collect_items, OffscreenRenderer):

    python -m bench.frame_digests > after.txt
    (cd ../old && python -m bench.frame_digests) > before.txt   # or a copy of this file
"""
from __future__ import annotations

import hashlib
import pathlib
import sys

import numpy as np

CAPTURES = ("guitar.ply", "test64.ply")
FRAMES = (1, 5, 9)
ARRAYS = ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")


def _digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def _scene(bpy, testdata, capture, kind):
    from addon.blender.data.files import import_file

    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = import_file(bpy.context, str(testdata / capture))
    if kind is None:
        return obj
    bpy.context.view_layer.objects.active = obj
    with bpy.context.temp_override(object=obj):
        bpy.ops.splatline.effect_add(type=kind)
    effect = obj.splatline.effects[-1]
    if kind == "MORPH":
        target = import_file(bpy.context, str(testdata / capture))
        target.location.x += 0.5
        target.splatline.look.visible = False
        effect.target = target
    for frame, amount in ((1, 0.2), (9, 1.0)):
        effect.amount = amount
        effect.keyframe_insert("amount", frame=frame)
    return obj


def rows(testdata: pathlib.Path):
    import bpy

    from addon.blender.evaluate.items import collect_items
    from addon.core import camera as core_camera
    from addon.core.effects import KINDS
    from addon.gl import OffscreenRenderer

    renderer = OffscreenRenderer()
    try:
        for capture in CAPTURES:
            for kind in (None, *sorted(KINDS)):
                obj = _scene(bpy, testdata, capture, kind)
                for frame in FRAMES:
                    bpy.context.scene.frame_set(frame)
                    items = [i for i in collect_items(bpy.context.evaluated_depsgraph_get())
                             if i.key[0] == obj.name_full]
                    item = items[0]
                    splats = _digest(*(getattr(item.splats, a) for a in ARRAYS))
                    cam = _camera(core_camera, item)
                    frame_digest = _digest(renderer.render(items, cam).rgba)
                    yield capture, kind or "none", frame, splats, frame_digest
    finally:
        renderer.close()


def _camera(core_camera, item):
    world = item.splats.positions.astype(np.float64) @ item.world[:3, :3].T + item.world[:3, 3]
    centre = np.median(world, axis=0)
    eye = centre + np.array([0.6, -2.5, 0.5])
    return core_camera.simple_camera(96, 72, 45.0, core_camera.look_at(eye, centre),
                                     near=0.05, far=50.0)


def main() -> None:
    import addon

    from testing.paths import REPO

    addon.register()
    testdata = REPO.parent / "shared" / "testdata"
    print(f"{'capture':<11} {'effect':<9} {'frame':>5}  {'splats':<16}  {'frame digest':<16}")
    for capture, kind, frame, splats, image in rows(testdata):
        print(f"{capture:<11} {kind:<9} {frame:>5}  {splats:<16}  {image:<16}", flush=True)


if __name__ == "__main__":
    sys.exit(main())
