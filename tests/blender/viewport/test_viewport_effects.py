"""The colour effects the viewport applies in its preprocess pass (viewport_effects.glsl)
pinned to the numpy kernels, record by record, across each effect's parameters.

One draw holds two copies of a real capture (guitar.ply, with its importer's axes, every
sixth splat; every third for the morph) under a turned gizmo: the first with the stack evaluated on the CPU, the
second with its colour effects deferred (core/effects/deferral.py) and the base splats
uploaded. Their preprocess records (opacity, conic, radius, colour) must agree within
what the two paths' half-float rounding allows: the CPU path rounds the scales and SH DC
to halves after the effect, the deferred one before it.
"""
from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest

from addon.core.effects import Displace, evaluate_stack
from addon.core.effects.deferral import split_stack
from addon.core.formats import read
from addon.core.scene import RenderItem
from addon.core.render_constants import ALPHA_MIN
from addon.core.sh import C0
from testing.effect_cases import grades, reveals
from testing.gl_scenes import framing_camera, world_for
from testing.viewport_scene import by_splat, draw_offscreen, records

HALF_STEP = 2.0 ** -11  # a half's rounding, relative, to nearest
DISPLACE = Displace(amplitude=0.08, frequency=2.0)


def colour_only(p) -> bool:
    """The viewport's taker without the displace: here a displace is the CPU's mover that
    puts the drawn centres apart from the rest ones (test_viewport_displace.py defers it)."""
    from addon.blender.viewport.effect_rows import on_gpu

    return type(p) is not Displace and on_gpu(p)


@pytest.fixture(scope="module")
def capture(testdata):
    full = read(testdata / "guitar.ply")
    keep = np.arange(0, full.count, 3)
    splats = replace(full, **{f: getattr(full, f)[keep] for f in
                              ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")})
    world = world_for(splats)
    return splats, world, framing_camera(RenderItem(splats, world), 160, 120)


def halves(a):
    return np.asarray(a, np.float32).astype(np.float16).astype(np.float32)


def cases():
    """Each reveal and grade by height or distance the viewport takes, alone, before a
    displace (measured at the rest centres: the rest texture) and after one. The
    test sets thresholds and ranges within the capture's own field values (_fitted)."""
    from addon.blender.viewport.effect_rows import on_gpu

    effects = [p for p in itertools.chain(reveals(), grades()) if on_gpu(p)]
    places = itertools.cycle(("alone", "before", "after"))
    for p, place in zip(effects, places):
        yield {"alone": [p], "before": [p, DISPLACE], "after": [DISPLACE, p]}[place]


def _fitted(p, splats):
    """p with its threshold or range moved into the capture's field values (the cases'
    -0.5..2 as fractions of its middle 80%), so that each case draws both sides."""
    f = _field_at(splats.positions, splats.positions, p)
    lo, hi = np.quantile(f, (0.1, 0.9))

    def at(x):  # the cases' values, 0..1 across the middle of the capture
        return float(lo + (hi - lo) * x)

    if hasattr(p, "shape"):
        return replace(p, progress=at(0.5 + 0.5 * p.progress), width=p.width * float(hi - lo))
    return replace(p, low=at(p.low), high=at(p.high))


def _ids(stack):
    p = next(q for q in stack if q is not DISPLACE)
    return f"{type(p).__name__}-{getattr(p, 'shape', getattr(p, 'field', ''))}-{len(stack)}"


CASES = list(cases())


def test_the_cases_meet_every_branch():
    deferred = [split_stack(s, colour_only)[1] for s in CASES]
    assert all(len(d) == 1 for d in deferred)
    assert {d[0].at_rest for d in deferred} == {True, False}
    reveal = [d[0].params for d in deferred if hasattr(d[0].params, "shape")]
    grade = [d[0].params for d in deferred if hasattr(d[0].params, "mode")]
    assert {p.shape for p in reveal} == {"PLANE", "SPHERE", "NOISE"}
    for what in (lambda p: p.invert, lambda p: p.width > 0, lambda p: p.shrink > 0,
                 lambda p: p.glow_strength > 0, lambda p: p.amount < 1):
        assert len({what(p) for p in reveal}) == 2
    assert {(p.field, p.mode, len(p.stops)) for p in grade} >= {
        (f, m, k) for f in ("HEIGHT", "DISTANCE", "NOISE") for m in ("MIX", "MULTIPLY", "ADD")
        for k in (2, 3)}
    assert any(p.low == p.high for p in grade)


@pytest.mark.parametrize("stack", CASES, ids=[_ids(s) for s in CASES])
def test_deferred_effects_draw_the_kernels_records(gpu_ready, capture, stack):
    splats, world, camera = capture
    splats = splats.subset(np.arange(0, splats.count, 2))  # every sixth: 72 cases, each small
    stack = [p if p is DISPLACE else _fitted(p, splats) for p in stack]
    time = 0.9
    on_cpu, deferred = split_stack(stack, colour_only)
    assert len(deferred) == 1
    cpu = evaluate_stack(splats, stack, time).splats
    part = evaluate_stack(splats, on_cpu, time).splats
    n = splats.count
    items = [RenderItem(cpu, world, key=("cpu",)),
             RenderItem(part, world, key=("gpu",), deferred=deferred, rest_positions=splats.positions)]
    order, rec = records(items, camera)
    want, got = by_splat(order, rec, n)
    assert len(want) > 0.3 * n  # the capture is in view
    assert set(want) <= set(got)  # the base scales bound the culling radius
    both = np.array(sorted(want), np.int64)
    w = np.stack([want[i] for i in both])
    g = np.stack([got[i] for i in both])
    _check(w, g, both, splats, cpu, part, deferred[0].params)


def _check(w, g, index, splats, cpu, part, params):
    """Field by field, the bound that the two roundings allow: the halves (scales, DC),
    and the field's own float rounding (the GPU may fuse its multiply-adds), carried
    through the effect's slope."""
    culled_w, culled_g = ~w.any(1), ~g.any(1)
    slack = _slack(splats, cpu, part, params, index)
    edge = slack["edge"] | (np.abs(cpu.opacities[index] - ALPHA_MIN) <= slack["opacity"] + 1e-6)
    flips = culled_w != culled_g
    assert not (flips & ~edge).any(), f"{int((flips & ~edge).sum())} splats culled on one side only"
    ok = ~culled_w & ~culled_g & ~edge
    assert ok.sum() > 0.1 * index.size
    w, g = w[ok], g[ok]
    slack = {k: np.broadcast_to(v, ok.shape)[ok] for k, v in slack.items()}
    assert (np.abs(g[:, 7] - w[:, 7]) <= slack["opacity"] + 2.0 ** -22 * w[:, 7]).all(), "opacity"
    np.testing.assert_allclose(g[:, 0:3], w[:, 0:3], rtol=0, atol=1e-4, err_msg="centre, depth")
    # scales: halves(s * k) against halves(s) * k, each within a half's rounding, and k's slack
    scale_error = 2.0 * HALF_STEP + 2e-7 + slack["scale"]
    conic_tol = 4.0 * scale_error[:, None] * np.abs(w[:, 4:7]).max(1, keepdims=True) + 1e-7
    assert (np.abs(g[:, 4:7] - w[:, 4:7]) <= conic_tol).all(), "conic"
    assert (np.abs(g[:, 3] - w[:, 3]) <= scale_error * np.abs(w[:, 3]) + 1e-3).all(), "radius"
    dc_cpu = np.abs(cpu.sh_dc[index][ok])
    dc_base = np.abs(part.sh_dc[index][ok])
    colour_tol = C0 * HALF_STEP * (dc_cpu + 2.0 * dc_base) + slack["colour"][:, None] + 1e-5
    assert (np.abs(g[:, 8:11] - w[:, 8:11]) <= colour_tol).all(), "colour"


def _slack(splats, cpu, part, params, index) -> dict:
    """Per splat, how far float rounding of the field may move each record, and `edge`:
    where it may put a hard edge's splat on the other side."""
    from addon.core.effects.common import inverse

    rows = np.abs(inverse(params.frame)[:3])
    df = np.full(index.size, 2.0 ** -24)  # noise: the same values, mapped by the same operations
    for centres in (() if _kind(params) == "NOISE" else (splats.positions, part.positions)):
        c = np.abs(np.asarray(centres[index], np.float64))
        terms = c @ rows[:, :3].T + rows[:, 3]  # |x r0| + |y r1| + |z r2| + |r3| per axis
        df = np.maximum(df, 8.0 * 2.0 ** -24 * np.linalg.norm(terms, axis=1))
    out = {"edge": np.zeros(index.size, bool), "opacity": np.zeros(index.size),
           "scale": np.zeros(index.size), "colour": np.zeros(index.size)}
    if hasattr(params, "shape"):  # reveal: s moves by df / width, visibility by 1.5 ds
        if params.width <= 0.0:
            out["edge"] = _field_near(splats, part, params, index, df)
            return out
        ds = df / params.width
        out["opacity"] = np.asarray(splats.opacities[index], np.float64) * params.amount * 1.5 * ds
        # relative to the scale factor k itself (the kernel's, read off its scales)
        k = np.abs(cpu.scales[index, 0] / splats.scales[index, 0]) if params.shrink > 0.0 else 1.0
        out["scale"] = params.amount * params.shrink * 1.5 * ds / np.maximum(k, 1e-6)
        out["colour"] = 4.0 * params.amount * params.glow_strength * ds * max(map(abs, params.glow_color))
        return out
    # grade: x moves by df / (high - low), the gradient by its steepest slope
    span = params.high - params.low
    stops = sorted(params.stops, key=lambda s: s[0])
    slopes = [max(abs(np.subtract(b[1], a[1]))) / (b[0] - a[0]) for a, b in zip(stops, stops[1:])
              if b[0] > a[0]]
    steps = [b[0] for a, b in zip(stops, stops[1:]) if b[0] == a[0]]
    dx = df / abs(span) if span else 0.0  # low == high: a step at low, flat elsewhere
    base = np.abs(C0 * splats.sh_dc[index] + 0.5).max(1)  # multiply scales the gradient's error
    out["colour"] = params.amount * max(slopes, default=0.0) * dx * np.maximum(1.0, base)
    kinks = [params.low + at * span for at in steps + [0.0, 1.0]]  # a step, the clip's ends
    for f in _fields(splats, part, params, index):
        for at in kinks:  # where f may cross one, the slope bound does not hold
            out["edge"] |= np.abs(f - at) <= 2.0 * df
    return out


def _kind(params) -> str:
    """The field a reveal's shape or a grade's field measures (common.field_values' kinds)."""
    shape = getattr(params, "shape", None)
    return {"PLANE": "HEIGHT", "SPHERE": "DISTANCE"}.get(shape, shape) or params.field


def _field_at(centres, rest, params) -> np.ndarray:
    """common.field_values of the effect's kind (noise: at the rest centres, memoized)."""
    from addon.core.effects.common import field_values
    from addon.core.effects.noise import rest_field

    kind = _kind(params)
    noise = rest_field(None, rest, params) if kind == "NOISE" else None
    return field_values(centres, params.frame, kind, noise).astype(np.float64)


def _fields(splats, part, params, index):
    """The field at the rest centres and at the drawn ones (a deferred effect reads one)."""
    return [_field_at(c, splats.positions, params)[index] for c in (splats.positions, part.positions)]


def _field_near(splats, part, params, index, df) -> np.ndarray:
    near = np.zeros(index.size, bool)
    for f in _fields(splats, part, params, index):
        near |= np.abs(f - params.progress) <= 2.0 * df
    return near


def test_scrubbing_a_stack_in_blender_uploads_only_the_order(bpy_empty, gpu_ready, testdata):
    """Through Blender: a capture imported by the import operator, a reveal, a displace and
    a grade added by the effect operator. The viewport's evaluation defers all three, so a
    scrubbed frame uploads the order and the table, but no centres (the displace moves its
    copy of the rest centres by the noise layers, uploaded once a layer) and no colour; it
    draws what the whole stack evaluated on the CPU draws."""
    from addon.core.effects import Grade, Reveal

    bpy = bpy_empty
    assert bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "guitar.ply")) == {"FINISHED"}
    obj = bpy.context.active_object
    with bpy.context.temp_override(object=obj):
        for kind in ("REVEAL", "DISPLACE", "GRADE"):
            assert bpy.ops.splatline.effect_add(type=kind) == {"FINISHED"}
    reveal, displace, grade = obj.splatline.effects
    reveal.glow_strength, grade.range_low, grade.range_high = 1.0, -1.0, 1.0
    for frame, progress in ((1, -1.0), (20, 1.0)):
        reveal.progress = progress
        reveal.keyframe_insert("progress", frame=frame)

    # frames 8, 10 and 12 blend the same two noise layers: frame 8 draws the CPU's centres
    # (new layers), frame 10 uploads the layers, frame 12 neither; the pos texture holds
    # the centres before displace moves them, where the reveal measures: no "rest" texture
    gpu = _scrub(bpy, (8, 10, 12), [Reveal, Displace, Grade], {"displace_a", "displace_b"})
    assert "rest" not in gpu.textures


def _scrub(bpy, frames, kinds, textures):
    """Scrub through `frames` in one viewport renderer: the viewport's evaluation defers
    `kinds`, the renderer holds `textures` before the last frame, which uploads the order
    and the table alone (no centres: the pass moves them itself), and draws what the
    whole stack evaluated on the CPU draws. Returns the renderer's gpu half."""
    from addon.blender.evaluate.items import collect_items
    from addon.blender.viewport import ViewportRenderer, packing
    from addon.blender.viewport.effect_rows import on_gpu
    from testing.viewport_scene import psnr

    def at(frame, defer):
        bpy.context.scene.frame_set(frame)
        return collect_items(bpy.context.evaluated_depsgraph_get(), defer)

    first = at(frames[0], on_gpu)
    assert [type(d.params) for d in first[0].deferred] == kinds
    camera = framing_camera(first[0], 160, 120)
    renderer = ViewportRenderer()
    draw_offscreen(first, camera, renderer=renderer)
    for frame in frames[1:-1]:
        draw_offscreen(at(frame, on_gpu), camera, renderer=renderer)
    assert textures <= set(renderer.gpu.textures)
    later = at(frames[-1], on_gpu)
    image, _ = draw_offscreen(later, camera, renderer=renderer)
    order = 4 * packing.padded(renderer.stats.drawn)  # the splats in view
    assert order <= renderer.stats.frame_bytes < order + 4096  # the order and the table
    whole = at(frames[-1], None)
    assert not whole[0].deferred
    assert psnr(image, draw_offscreen(whole, camera)[0]) > 60.0
    assert psnr(image, draw_offscreen(first, camera)[0]) < 40.0  # the frames differ
    return renderer.gpu


# radians: rounding the three smallest components (each <= 1/sqrt(2), so within 2^-12) to
# halves moves a quaternion by |dq| <= 3 2^-12, a turn by twice that; once on each path
ROTATION_STEP = 2.0 * 6.0 * 2.0 ** -12


def _morph_scene(splats, t):
    """A morph of `splats` to themselves turned, moved, grown and recoloured (paired in
    order), with its params."""
    from addon.core.effects import Morph, pair

    c, s = np.cos(0.6), np.sin(0.6)
    turn = np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]], np.float32)
    rng = np.random.default_rng(8)
    rotations = splats.rotations[::-1].copy()
    # every fifth pair half a turn apart (q.q' = 0 but for rounding): either arc is as
    # short, and the drawing must take the kernel's
    q, axis = splats.rotations[::5].astype(np.float64), np.array([0.0, 0.6, 0.8])
    rotations[::5, 0] = -(q[:, 1:] @ axis)
    rotations[::5, 1:] = q[:, :1] * axis + np.cross(axis, q[:, 1:])
    other = replace(splats, positions=splats.positions @ turn.T + np.float32(0.1),
                    opacities=np.float32(1.0) - splats.opacities,
                    scales=splats.scales * rng.uniform(0.5, 2.0, splats.scales.shape).astype(np.float32),
                    sh_dc=splats.sh_dc[::-1].copy(), sh_rest=splats.sh_rest[::-1].copy(),
                    rotations=rotations)
    return Morph(target=other, pairing=pair(splats.positions, other.positions), amount=t)


@pytest.mark.parametrize("scene", ("guitar", "degree 3", "guitar to a third", "a third to guitar"))
@pytest.mark.parametrize("t, then_grade", ((0.2, False), (0.5, True), (0.85, False)))
def test_a_deferred_morph_draws_the_kernels_records(gpu_ready, capture, testdata, scene, t, then_grade):
    """A morph blended in the preprocess pass against the kernel's blend uploaded whole:
    guitar (degree 0) with its axes, a degree-3 set (test64.ply and generated splats) for
    the SH bands, and guitar into a third of its turned self and back (paired along the
    Morton curve: handed over as its ends, the lone splats fading). The bar adds the
    rotations' rounding to the colour effects' bars."""
    from addon.blender.viewport.effect_rows import on_gpu
    from addon.core.effects import Grade
    from addon.core.effects.deferral import drawn_splats
    from addon.core.effects.morph import aligned
    from testing.synth import random_splats

    splats, world, camera = capture
    if scene == "degree 3":
        extra = random_splats(3000, 3, seed=5, spread=0.3)
        own = read(testdata / "test64.ply")
        splats = concatenated(own, extra)
        item = RenderItem(splats, np.eye(4))
        camera = framing_camera(item, 160, 120)
        world = np.eye(4)
    morph = _morph_scene(splats, t)
    if scene == "guitar to a third":
        morph = _morph_to(splats, morph.target.subset(np.arange(0, splats.count, 3)), t)
    elif scene == "a third to guitar":
        splats = splats.subset(np.arange(1, splats.count, 3))
        morph = _morph_to(splats, morph.target, t)
    stack = [morph] + ([Grade(low=-1.0, high=1.0, frame=np.eye(4))] if then_grade else [])
    on_cpu, deferred = split_stack(stack, on_gpu)
    assert on_cpu == [] and [type(d.params) for d in deferred][0] is type(morph)
    cpu = evaluate_stack(splats, stack, 0.0).splats
    drawn, handed = drawn_splats(evaluate_stack(splats, on_cpu, 0.0).splats, deferred)
    items = [RenderItem(cpu, world, key=("cpu",)), RenderItem(drawn, world, key=("gpu",), deferred=handed)]
    order, rec = records(items, camera)
    want, got = by_splat(order, rec, cpu.count)
    assert len(want) > 0.3 * cpu.count and set(want) <= set(got)
    index = np.array(sorted(want), np.int64)
    w, g = np.stack([want[i] for i in index]), np.stack([got[i] for i in index])
    ends = aligned(splats, morph.target, morph.pairing)
    _check_morph(w, g, index, ends.source, ends.target, cpu)


def _morph_to(splats, target, t):
    from addon.core.effects import Morph, pair

    pairing = pair(splats.positions, target.positions)
    assert not pairing.in_order
    return Morph(target=target, pairing=pairing, amount=t)


def concatenated(a, b):
    from addon.core.splats import ARRAYS, SplatSet

    return SplatSet(*(np.concatenate([getattr(a, f), getattr(b, f)]) for f in ARRAYS), axes=a.axes)


def _check_morph(w, g, index, source, target, cpu):
    opacity = np.asarray(cpu.opacities[index], np.float64)
    slack = 2.0 ** -22 * (np.abs(source.opacities[index]) + np.abs(target.opacities[index])) + 1e-7
    edge = np.abs(opacity - ALPHA_MIN) <= slack
    culled_w, culled_g = ~w.any(1), ~g.any(1)
    assert not ((culled_w != culled_g) & ~edge).any(), "culled on one side only"
    ok = ~culled_w & ~culled_g & ~edge
    assert ok.sum() > 0.5 * index.size
    w, g, slack = w[ok], g[ok], slack[ok]
    assert (np.abs(g[:, 7] - w[:, 7]) <= slack + 2.0 ** -22 * w[:, 7]).all(), "opacity"
    # the pass blends the centres from the ends itself; the GPU may fuse the lerp's
    # multiply-add, which moves a centre by ~1e-7 of itself (~1e-5 px here)
    np.testing.assert_allclose(g[:, 0:3], w[:, 0:3], rtol=0, atol=1e-4, err_msg="centre, depth")
    # the covariance moves by 2 (scale + rotation error) of its largest eigenvalue, and
    # its inverse, the conic, by that over the conic's smallest eigenvalue, squared
    a, b, c = w[:, 4], w[:, 5], w[:, 6]
    half_trace, root = 0.5 * (a + c), np.sqrt(0.25 * (a - c) ** 2 + b * b)
    big, small = half_trace + root, np.maximum(half_trace - root, 1e-12)
    # covariance: scales within two halves' rounding (relative), rotation within
    # ROTATION_STEP, which moves it by at most twice that times its eigenvalues' spread
    moved = 2.0 * (2.0 * HALF_STEP + 1e-6) / small + 2.0 * ROTATION_STEP * (1.0 / small - 1.0 / big)
    conic_tol = 2.0 * moved * big * big + 1e-7  # first order, doubled
    assert (np.abs(g[:, 4:7] - w[:, 4:7]) <= conic_tol[:, None]).all(), "conic"
    radius_tol = (2.0 * HALF_STEP + ROTATION_STEP) * np.abs(w[:, 3]) + 1e-3
    assert (np.abs(g[:, 3] - w[:, 3]) <= radius_tol).all(), "radius"
    bands = [np.abs(s.sh_rest[index][ok]).sum(1) for s in (source, target, cpu)]
    dcs = [np.abs(s.sh_dc[index][ok]) for s in (source, target, cpu)]
    colour_tol = HALF_STEP * (C0 * sum(dcs) + 1.1 * sum(bands)) + 1e-5
    assert (np.abs(g[:, 8:11] - w[:, 8:11]) <= colour_tol).all(), "colour"


@pytest.mark.parametrize("source_name, target_name", (("guitar.ply", "guitar.ply"),
                                                       ("guitar.ply", "test64.ply"),
                                                       ("test64.ply", "guitar.ply")))
def test_scrubbing_a_morph_in_blender_uploads_only_the_order(bpy_empty, gpu_ready, testdata,
                                                               source_name, target_name):
    """Two captures imported by the import operator (the second turned and moved), a morph
    between them added by the effect operator, its amount keyframed: the viewport's
    evaluation defers the morph, so a scrubbed frame uploads the order and the table alone
    (the pass blends the centres from the ends' own, uploaded once), and draws what the
    kernel's blend uploaded whole draws. Of the same size (paired in order) and of others
    (90,854 and 64 splats, either way: the ends morph.aligned gathers once)."""
    from addon.core.effects import Morph

    bpy = bpy_empty
    source, target = (_imported(bpy, testdata / name) for name in (source_name, target_name))
    target.location, target.rotation_euler = (0.4, 0.0, 0.3), (1.2, 0.0, 0.5)
    target.splatline.look.visible = False
    with bpy.context.temp_override(object=source):
        assert bpy.ops.splatline.effect_add(type="MORPH") == {"FINISHED"}
    morph = source.splatline.effects[0]
    morph.target = target
    for frame, amount in ((1, 0.0), (20, 1.0)):
        morph.amount = amount
        morph.keyframe_insert("amount", frame=frame)

    _scrub(bpy, (6, 13), [Morph], {"morph_pos", "morph_shape", "morph_sh", "morph_centres"})


def _imported(bpy, path):
    assert bpy.ops.import_scene.splatline_gaussians(filepath=str(path)) == {"FINISHED"}
    return bpy.context.active_object


def test_rendered_shading_defers_too_and_final_renders_never(bpy_empty, testdata):
    """The rendered viewport (the engine's view_update and view_draw) evaluates as the draw
    handler does; the engine's final frames evaluate the whole stack."""
    from addon.blender.evaluate.items import collect_items
    from addon.blender.render import engine
    from addon.core.effects import Reveal

    bpy = bpy_empty
    assert bpy.ops.import_scene.splatline_gaussians(filepath=str(testdata / "guitar.ply")) == {"FINISHED"}
    with bpy.context.temp_override(object=bpy.context.active_object):
        assert bpy.ops.splatline.effect_add(type="REVEAL") == {"FINISHED"}
    depsgraph = bpy.context.evaluated_depsgraph_get()
    (shaded,) = engine._viewport_items(depsgraph)
    assert [type(d.params) for d in shaded.deferred] == [Reveal]
    (final,) = collect_items(depsgraph)
    assert not final.deferred and final.splats.opacities is not shaded.splats.opacities
