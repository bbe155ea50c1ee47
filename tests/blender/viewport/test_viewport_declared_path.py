"""An effect reaches the viewport's GPU path by its kind's declaration alone (EffectKind.gpu,
core/effects/kind.GpuPath): a throwaway kind declaring the "reveal" program, with its
params mapped onto a Reveal's, is deferred (core/effects/deferral.py), drawn by the
preprocess pass with nothing uploaded per splat while scrubbing, and draws what the CPU
path draws; the same kind without a declaration stays on the CPU."""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pytest

from addon.core.effects import Displace, EffectParams, Grade, Reveal, evaluate_stack, registry
from addon.core.effects.common import F32, field_values, smoothstep01
from addon.core.effects.deferral import apply_deferred, split_stack
from addon.core.effects.kind import EffectKind, Field, GpuPath
from addon.core.formats import read
from testing.capture_scenes import own_item, place
from testing.effect_ops import add_effect
from testing.gl_scenes import framing_camera
from testing.viewport_scene import draw_offscreen, overlay_drawn, psnr

ARRAYS = ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")


# -- a throwaway effect: splats above a height fade out -----------------------------------
@dataclass
class Fade(EffectParams):
    height: float = 0.0     # gizmo-local z where opacity is halfway faded
    softness: float = 0.2   # the height over which it fades


def fade(splats, p: Fade, time: float = 0.0, rest=None):
    """opacity *= 1 - amount (1 - smoothstep(below)), below = 1 well under `height`, 0
    well over it, linear across `softness`."""
    if not p.active or splats.count == 0:
        return splats
    z = field_values(splats.positions, p.frame, "HEIGHT")
    below = np.clip((z - F32(p.height)) * F32(-1.0 / p.softness) + F32(0.5), 0.0, 1.0)
    gone = F32(1.0) - smoothstep01(below)
    return replace(splats, opacities=splats.opacities * (F32(1.0) - F32(p.amount) * gone))


def as_reveal(p: Fade) -> Reveal:
    """A fade is a plane reveal that neither shrinks nor glows."""
    return Reveal(enabled=p.enabled, amount=p.amount, frame=p.frame, shape="PLANE",
                  progress=p.height, width=p.softness, shrink=0.0, glow_strength=0.0)


FIELDS = (Field("fade_height", "FLOAT", "Height", 0.0, param="height"),
          Field("fade_softness", "FLOAT", "Softness", 0.2, param="softness", options={"min": 0.01}))
FADE = EffectKind("TEST_FADE", 92, "Fade", "Splats above a height fade out", "MOD_MASK", Fade, fade,
                  moves_splats=False, depends_on_time=False, writes=frozenset({"opacities"}),
                  fields=FIELDS, gpu=GpuPath("reveal", as_reveal))


@dataclass
class CpuFade(Fade):
    pass


# the same kernel, undeclared
CPU_FADE = replace(FADE, id="TEST_CPU_FADE", number=93, label="CPU Fade", params=CpuFade, gpu=None)


@pytest.fixture
def fades_in_table():
    for kind in (FADE, CPU_FADE):
        registry.add(kind)
    try:
        yield
    finally:
        for kind in (FADE, CPU_FADE):
            registry.remove(kind.id)


def _reregister(bpy):
    from addon import register, unregister

    bpy.ops.wm.read_factory_settings(use_empty=True)  # no item holds the types being dropped
    unregister()
    register()


@pytest.fixture
def with_fades(bpy_empty):
    """The fades in the table and in Blender's Effect property group; both gone after, so
    later tests (the kinds' coverage checks) see the built-in table only."""
    for kind in (FADE, CPU_FADE):
        registry.add(kind)
    try:
        _reregister(bpy_empty)
        yield bpy_empty
    finally:
        for kind in (FADE, CPU_FADE):
            registry.remove(kind.id)
        _reregister(bpy_empty)


def test_a_declaration_names_a_program_the_pass_has_and_writes_within_it():
    with pytest.raises(ValueError, match="'blur'"):
        GpuPath("blur")
    with pytest.raises(ValueError, match="TEST_FADE: the 'reveal' program writes only") as caught:
        replace(FADE, writes=frozenset({"opacities", "positions"}))
    assert "\n" not in str(caught.value)


# -- split_stack defers it as its program; applied as that program it is the stack --------
def _turned() -> np.ndarray:
    c, s = np.cos(0.5), np.sin(0.5)
    m = np.eye(4)
    m[:3, :3] = [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]
    m[:3, 3] = (0.1, -0.2, 0.05)
    return m


STACKS = {  # stack -> the programs split_stack defers, in order
    "fade": (lambda f: [f], ["reveal"]),
    "fade, displace": (lambda f: [f, Displace(amplitude=0.05, frequency=2.0)], ["reveal", "displace"]),
    "displace, fade": (lambda f: [Displace(amplitude=0.05, frequency=2.0), f], ["displace", "reveal"]),
    "grade, fade": (lambda f: [Grade(low=-1.0, high=1.0, frame=_turned()), f], ["grade", "reveal"]),
    "undeclared": (lambda f: [CpuFade(**vars(f))], []),
}


@pytest.mark.parametrize("name", STACKS)
def test_a_declared_kind_is_deferred_as_its_program_and_is_the_stack_bit_for_bit(
        fades_in_table, testdata, name):
    from addon.blender.viewport.effect_rows import on_gpu

    splats = read(testdata / "guitar.ply")
    z = field_values(splats.positions, _turned(), "HEIGHT")
    f = Fade(amount=0.8, frame=_turned(), height=float(np.median(z)), softness=float(np.ptp(z)) / 4)
    build, programs = STACKS[name]
    stack = build(f)
    on_cpu, deferred = split_stack(stack, on_gpu)
    assert [d.program for d in deferred] == programs
    assert on_cpu == ([] if programs else stack)
    for d in deferred:
        if d.program == "reveal":  # handed over as the program's params
            assert type(d.params) is Reveal
            assert (d.params.progress, d.params.width, d.params.shrink, d.params.amount) == \
                (f.height, f.softness, 0.0, 0.8)
            assert d.params.frame is f.frame
    want = evaluate_stack(splats, stack, 1.3).splats
    part = evaluate_stack(splats, on_cpu, 1.3).splats
    got = apply_deferred(part, splats.positions, deferred, 1.3)
    assert not np.array_equal(want.opacities, splats.opacities)  # the fade did something
    for a in ARRAYS:
        np.testing.assert_array_equal(getattr(got, a), getattr(want, a), err_msg=a)


# -- through Blender: the viewport's evaluation defers it and the pass draws it ------------
def _collect(bpy, frame, defer):
    from addon.blender.evaluate.items import collect_items

    bpy.context.scene.frame_set(frame)
    return collect_items(bpy.context.evaluated_depsgraph_get(), defer)


def _faded_capture(bpy, testdata, kind_id):
    """guitar.ply imported with its axes, a fade under a turned gizmo, its height keyframed
    from the capture's 20th height percentile at frame 1 to its 80th at frame 20."""
    obj = overlay_drawn(place(bpy, testdata, "guitar.ply"))
    gizmo = bpy.data.objects.new("fade gizmo", None)
    bpy.context.scene.collection.objects.link(gizmo)
    gizmo.rotation_euler = (0.5, 0.2, 0.0)
    effect = add_effect(bpy, obj, kind_id, amount=0.9, gizmo=gizmo)
    frame = _collect(bpy, 1, None)[0]
    z = field_values(own_item(bpy, obj, 1).splats.positions, _gizmo_frame(bpy, obj, effect), "HEIGHT")
    low, high = np.percentile(z, (20, 80))
    effect.fade_softness = float(high - low) / 3
    for at, height in ((1, low), (20, high)):
        effect.fade_height = float(height)
        effect.keyframe_insert("fade_height", frame=at)
    return obj, framing_camera(frame, 160, 120)


def _gizmo_frame(bpy, obj, effect):
    """The effect's field frame, as the evaluator builds it."""
    from addon.blender.evaluate.effect_params import gizmo_frame

    depsgraph = bpy.context.evaluated_depsgraph_get()
    return gizmo_frame(effect, np.array(obj.evaluated_get(depsgraph).matrix_world, np.float64), depsgraph)


def test_the_viewport_draws_a_declared_kind_in_its_preprocess_pass(with_fades, testdata):
    """Scrubbing the fade's height uploads no splat data (the pos texture keeps the base's
    opacities, the pass fades them) and sorts nothing; each frame draws what the whole
    stack evaluated on the CPU draws; apply_deferred on the viewport's item is the CPU's
    item bit for bit."""
    from addon.blender.viewport import ViewportRenderer
    from addon.blender.viewport.effect_rows import on_gpu
    from testing.headless import ensure_gpu

    bpy = with_fades
    ensure_gpu()
    obj, camera = _faded_capture(bpy, testdata, "TEST_FADE")
    own = own_item(bpy, obj, 1)
    renderer = ViewportRenderer()
    first = _collect(bpy, 1, on_gpu)
    assert [d.program for d in first[0].deferred] == ["reveal"]
    assert first[0].splats.opacities is own.splats.opacities  # the CPU left them alone
    image, _ = draw_offscreen(first, camera, renderer=renderer)
    sorts, uploads = renderer.stats.sorts, renderer.stats.uploads
    for frame in (6, 11, 16):
        item = _collect(bpy, frame, on_gpu)
        image, _ = draw_offscreen(item, camera, renderer=renderer)
        assert (renderer.stats.sorts, renderer.stats.uploads) == (sorts, uploads)
        assert renderer.stats.frame_bytes < 4096  # the table alone
        whole = _collect(bpy, frame, None)
        assert not whole[0].deferred
        assert psnr(image, draw_offscreen(whole, camera)[0]) > 60.0
        got = apply_deferred(item[0].splats, item[0].rest_positions, item[0].deferred,
                             frame / bpy.context.scene.render.fps)
        for a in ARRAYS:
            np.testing.assert_array_equal(getattr(got, a), getattr(whole[0].splats, a), err_msg=a)
    assert psnr(image, draw_offscreen(first, camera)[0]) < 40.0  # the frames differ


def test_an_undeclared_kind_stays_on_the_cpu(with_fades, testdata):
    """The same kernel without a declaration: evaluated on the CPU in the viewport too, so
    each scrubbed frame re-uploads the faded opacities."""
    from addon.blender.viewport import ViewportRenderer
    from addon.blender.viewport.effect_rows import on_gpu
    from testing.headless import ensure_gpu

    bpy = with_fades
    ensure_gpu()
    obj, camera = _faded_capture(bpy, testdata, "TEST_CPU_FADE")
    renderer = ViewportRenderer()
    draw_offscreen(_collect(bpy, 1, on_gpu), camera, renderer=renderer)
    uploads = renderer.stats.uploads
    for n, frame in enumerate((6, 11), 1):
        (item,) = _collect(bpy, frame, on_gpu)
        assert not item.deferred
        assert not np.array_equal(item.splats.opacities, own_item(bpy, obj, frame).splats.opacities)
        image, _ = draw_offscreen([item], camera, renderer=renderer)
        assert renderer.stats.uploads == uploads + n  # the opacities, each frame
        assert psnr(image, draw_offscreen([item], camera)[0]) == float("inf")
