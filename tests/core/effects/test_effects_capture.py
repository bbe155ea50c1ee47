"""Every effect (each type and each frame-dependent field, shape or mode) on the real
captures with their real transform, checked against its stated end state in world terms.

guitar.ply and test64.ply are imported as a user imports them (the RDF axes sit as a
rotation on the object), then either left so ("imported") or parented to a moved, turned,
uniformly scaled Empty ("parented"). Without a gizmo a field is world-aligned at the
object's origin in world units (effect_params.field_frame); motions are rigid in object
space, which for these similarity transforms is rigid in the world, scaled by the object's
world scale. So every expectation below is written with world positions only:
h = world z - origin z, distance = |world - origin|, radius from the world Z axis.

COVERAGE at the bottom fails when an effect type, a field/shape/mode or a bundled effect
preset has no real-capture check (here, or in test_presets_capture.py for the presets).
"""
from __future__ import annotations

import ast
import json
import math

import numpy as np
import pytest

from addon.blender.data.files import import_file
from addon.core.effects.noise import field as noise_field
from addon.core.preprocess import quat_to_matrix
from addon.core.sh import C0, sh_to_rgb
from testing.capture_scenes import item_at, place
from testing.effect_ops import add_effect as _add
from testing.paths import REPO, TESTS

CAPTURES = ("guitar.ply", "test64.ply")
TRANSFORMS = ("imported", "parented")


# -- the scene ----------------------------------------------------------------------------




class Scene:
    """One capture: its splats without effects (rest) and with them (out), in world terms."""

    def __init__(self, bpy, obj, frame=1):
        self.bpy, self.obj, self.frame = bpy, obj, frame
        for e in obj.splatline.effects:
            e.enabled = False
        self.rest = item_at(bpy, obj.name_full, frame)
        for e in obj.splatline.effects:
            e.enabled = True
        self.out = item_at(bpy, obj.name_full, frame)
        w = self.rest.world
        self.origin = w[:3, 3]
        self.scale = abs(np.linalg.det(w[:3, :3])) ** (1 / 3)
        self.rot = w[:3, :3] / self.scale
        self.before, self.after = self.world(self.rest), self.world(self.out)
        rel = self.before - self.origin
        self.h = rel[:, 2]
        self.distance = np.linalg.norm(rel, axis=1)
        self.axis_radius = np.linalg.norm(rel[:, :2], axis=1)
        self.size = float(np.ptp(self.before, axis=0).max())

    @staticmethod
    def world(item):
        return item.splats.positions.astype(np.float64) @ item.world[:3, :3].T + item.world[:3, 3]

    def world_rotations(self, item):
        r, ok = quat_to_matrix(item.splats.rotations)
        assert ok.all()
        return self.rot @ r


def _quantiles(values, *q):
    return [float(np.quantile(values, x)) for x in q]


def _split_sides(f, progress, width, own, got):
    """Reveal's stated end state: below progress - width/2 at the splat's own opacity,
    above progress + width/2 hidden, both sides well populated."""
    shown, hidden = f < progress - width / 2, f > progress + width / 2
    assert 0.2 < shown.mean() and 0.2 < hidden.mean()
    np.testing.assert_array_equal(got[shown], own[shown])
    assert got[hidden].max() == 0.0


# -- the checks: function(bpy, obj, path of the capture); each adds its effect, asserts ----
def reveal_plane(bpy, obj, capture):
    s = Scene(bpy, obj)
    progress = _quantiles(s.h, 0.5)[0]
    width = 0.05 * s.size
    _add(bpy, obj, "REVEAL", reveal_shape="PLANE", progress=progress, edge_width=width, shrink=0.0)
    s = Scene(bpy, obj)
    _split_sides(s.h, progress, width, s.rest.splats.opacities, s.out.splats.opacities)


def reveal_sphere(bpy, obj, capture):
    s = Scene(bpy, obj)
    progress = _quantiles(s.distance, 0.5)[0]
    width = 0.05 * s.size
    _add(bpy, obj, "REVEAL", reveal_shape="SPHERE", progress=progress, edge_width=width, shrink=1.0)
    s = Scene(bpy, obj)
    _split_sides(s.distance, progress, width, s.rest.splats.opacities, s.out.splats.opacities)
    hidden = s.distance > progress + width / 2
    assert s.out.splats.scales[hidden].max() == 0.0  # shrink 1: hidden splats vanish in size too


def reveal_noise(bpy, obj, capture):
    cells = 6.0 / Scene(bpy, obj).size  # noise cells per world unit: a few across the capture
    effect = _add(bpy, obj, "REVEAL", reveal_shape="NOISE", edge_width=0.1, frequency=cells)
    for progress, ends in ((1.1, "all shown"), (-0.1, "all hidden"), (0.5, "some of each")):
        effect.progress = progress
        s = Scene(bpy, obj)
        own, got = s.rest.splats.opacities, s.out.splats.opacities
        if ends == "all shown":
            np.testing.assert_array_equal(got, own)
        elif ends == "all hidden":
            assert got.max() == 0.0
        else:
            assert 0.05 < (got == own).mean() < 0.95 and 0.05 < (got == 0).mean() < 0.95


def displace(bpy, obj, capture):
    s = Scene(bpy, obj)
    amplitude = 0.02 * s.size / s.scale  # object units
    _add(bpy, obj, "DISPLACE", amplitude=amplitude, frequency=2.0, speed=0.5, seed=3)
    s = Scene(bpy, obj, frame=0)  # time 0: one noise layer, unblended
    moved = (s.out.splats.positions.astype(np.float64) - s.rest.splats.positions) / amplitude
    assert np.abs(moved).max() <= 1.0 + 1e-4 and np.abs(moved).std() > 0.05
    # sampled in the world-aligned frame at the object's origin, in world units
    frame = np.linalg.inv(s.rest.world) @ np.block([[np.eye(3), s.origin[:, None]], [0, 0, 0, 1]])
    want = np.stack(noise_field(s.rest.splats.positions, frame, 2.0, 3, 3, 0), axis=1)
    np.testing.assert_allclose(moved, want, atol=2e-4 * s.size / s.scale / amplitude)


def _explode(bpy, obj, mode):
    fps = bpy.context.scene.render.fps / bpy.context.scene.render.fps_base
    _add(bpy, obj, "EXPLODE", explode_mode=mode, strength=0.5, spread=0.0, gravity=0.3,
         start_frame=1.0, fade=0.5)
    s = Scene(bpy, obj, frame=1 + 24)
    tau = 24 / fps
    np.testing.assert_allclose(s.out.splats.opacities, s.rest.splats.opacities * math.exp(-0.5 * tau),
                               rtol=1e-5)
    fall = np.array([0.0, 0.0, -0.5 * 0.3 * tau * tau])  # along the gizmo's -Z: the world's
    return s, tau, fall


def explode_center(bpy, obj, capture):
    s, tau, fall = _explode(bpy, obj, "CENTER")
    rel = s.before - s.origin
    radial = rel / np.linalg.norm(rel, axis=1, keepdims=True)
    want = s.scale * (0.5 * tau * radial + fall)  # object units/s, scaled into the world
    np.testing.assert_allclose(s.after - s.before, want, atol=1e-4 * s.size)


def explode_direction(bpy, obj, capture):
    s, tau, fall = _explode(bpy, obj, "DIRECTION")
    want = s.scale * (np.array([0.0, 0.0, 0.5 * tau]) + fall)  # up the world's Z
    np.testing.assert_allclose(s.after - s.before, np.broadcast_to(want, s.before.shape),
                               atol=1e-4 * s.size)


def _rz(theta):
    c, s = np.cos(theta), np.sin(theta)
    r = np.zeros((len(theta), 3, 3))
    r[:, 0, 0], r[:, 0, 1], r[:, 1, 0], r[:, 1, 1], r[:, 2, 2] = c, -s, s, c, 1.0
    return r


def _check_turned(s, angle):
    """Centres and orientations turned about the world Z axis through the origin."""
    rz = _rz(angle)
    want = np.einsum("nij,nj->ni", rz, s.before - s.origin) + s.origin
    np.testing.assert_allclose(s.after, want, atol=1e-4 * s.size)
    np.testing.assert_allclose(s.world_rotations(s.out), rz @ s.world_rotations(s.rest), atol=2e-4)
    assert np.ptp(angle) > 0.3  # the turn varies across the capture


def twist(bpy, obj, capture):
    s = Scene(bpy, obj)
    rate = 2.0 / s.size  # radians per world unit of height
    _add(bpy, obj, "TWIST", twist=rate, swirl=0.0)
    s = Scene(bpy, obj)
    _check_turned(s, rate * s.h)


def swirl(bpy, obj, capture):
    s = Scene(bpy, obj)
    radius = _quantiles(s.axis_radius, 0.75)[0]
    _add(bpy, obj, "TWIST", twist=0.0, swirl=3.0, swirl_radius=radius)
    s = Scene(bpy, obj)
    _check_turned(s, 3.0 * np.exp(-(s.axis_radius / radius) ** 2))


def _grade(bpy, obj, field, low, high):
    cells = 6.0 / Scene(bpy, obj).size  # noise cells per world unit: a few across the capture
    _add(bpy, obj, "GRADE", grade_field=field, grade_mode="MIX", color_a=(0.0, 0.0, 1.0),
         color_b=(1.0, 0.0, 0.0), range_low=low, range_high=high, frequency=cells)
    s = Scene(bpy, obj)
    colour = C0 * s.out.splats.sh_dc.astype(np.float64) + 0.5  # MIX at amount 1: the gradient
    np.testing.assert_array_equal(s.out.splats.sh_rest, s.rest.splats.sh_rest)
    np.testing.assert_array_equal(s.out.splats.positions, s.rest.splats.positions)
    return s, colour


def _grade_ramp(bpy, obj, field, values):
    """At MIX the colour is the a-b gradient of the world field's values, 10-90 %."""
    low, high = _quantiles(values, 0.1, 0.9)
    s, colour = _grade(bpy, obj, field, low, high)
    x = np.clip((values - low) / (high - low), 0, 1)
    np.testing.assert_allclose(colour, np.c_[x, 0 * x, 1 - x], atol=1e-5)


def grade_height(bpy, obj, capture):
    _grade_ramp(bpy, obj, "HEIGHT", Scene(bpy, obj).h)


def grade_distance(bpy, obj, capture):
    _grade_ramp(bpy, obj, "DISTANCE", Scene(bpy, obj).distance)


def grade_noise(bpy, obj, capture):
    s, colour = _grade(bpy, obj, "NOISE", 0.0, 1.0)
    np.testing.assert_allclose(colour[:, 0] + colour[:, 2], 1.0, atol=1e-5)  # on the a-b line
    np.testing.assert_allclose(colour[:, 1], 0.0, atol=1e-5)
    assert np.ptp(colour[:, 0]) > 0.3


def morph(bpy, obj, capture):
    """At amount 1 the source is the target itself: where the target draws each splat, with
    its colour from any world direction (SH turned into the source's frame)."""
    target = import_file(bpy.context, str(capture))
    target.rotation_euler.rotate_axis("Z", math.radians(90))
    target.scale = (1.5, 1.5, 1.5)
    target.location = (0.5, -0.3, 0.2)
    _add(bpy, obj, "MORPH", target=target, amount=1.0)
    target.splatline.look.visible = False
    s = Scene(bpy, obj)
    target.splatline.look.visible = True
    want = item_at(bpy, target.name_full)
    ws = Scene.world(want)
    np.testing.assert_allclose(s.after, ws, atol=1e-5 * s.size)  # equal counts pair by index
    dirs = np.random.default_rng(1).normal(size=(want.splats.count, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)

    def colours(item):
        local = dirs @ np.linalg.inv(item.world[:3, :3]).T
        local /= np.linalg.norm(local, axis=1, keepdims=True)
        sp = item.splats
        return sh_to_rgb(sp.sh_dc, sp.sh_rest, local, sp.sh_degree)

    np.testing.assert_allclose(colours(s.out), colours(want), atol=2e-4)
    np.testing.assert_allclose(s.out.splats.opacities, want.splats.opacities, rtol=1e-6)


CHECKS = {
    "REVEAL": {"PLANE": reveal_plane, "SPHERE": reveal_sphere, "NOISE": reveal_noise},
    "DISPLACE": {"": displace},
    "EXPLODE": {"CENTER": explode_center, "DIRECTION": explode_direction},
    "TWIST": {"twist": twist, "swirl": swirl},
    "GRADE": {"HEIGHT": grade_height, "DISTANCE": grade_distance, "NOISE": grade_noise},
    "MORPH": {"": morph},
}
# The bundled presets' real-capture tests (both captures, three transforms each).
PRESET_TESTS = {
    "sweep_reveal": "test_sweep_reveal_shows_every_splat_at_its_own_opacity",
    "dissolve_out_noise": "test_dissolve_fade_and_glitch_reach_their_ends",
    "fade_in": "test_dissolve_fade_and_glitch_reach_their_ends",
    "glitch_displace": "test_dissolve_fade_and_glitch_reach_their_ends",
    "explode": "test_explode_bursts_from_the_centre_and_falls_down_the_world",
    "morph": "test_morph_ends_as_the_target_itself",
}
CASES = [(kind, variant) for kind, variants in CHECKS.items() for variant in variants]


@pytest.mark.parametrize("transform", TRANSFORMS)
@pytest.mark.parametrize("capture", CAPTURES)
@pytest.mark.parametrize("kind,variant", CASES, ids=[f"{k}-{v}" if v else k for k, v in CASES])
def test_effect_reaches_its_stated_state_on_a_real_capture(bpy_empty, testdata, capture, transform,
                                                          kind, variant):
    obj = place(bpy_empty, testdata, capture, transform)
    CHECKS[kind][variant](bpy_empty, obj, testdata / capture)


# -- coverage -------------------------------------------------------------------------------
def _enum(bpy, name):
    from addon.blender.props.effect import Effect

    prop = Effect.bl_rna.properties[name]
    return {item.identifier for item in prop.enum_items}


def test_every_effect_and_variant_has_a_real_capture_check(_bpy_registered):
    from addon.core.effects import KINDS

    bpy = _bpy_registered
    types = _enum(bpy, "type")
    assert set(CHECKS) == types, f"effect types without a real-capture check: {types - set(CHECKS)}"
    assert set(KINDS) == types  # a core kernel the panel does not offer is unchecked too
    variants = {"REVEAL": _enum(bpy, "reveal_shape"), "EXPLODE": _enum(bpy, "explode_mode"),
                "GRADE": _enum(bpy, "grade_field"), "TWIST": {"twist", "swirl"}}
    for kind, wanted in variants.items():
        assert set(CHECKS[kind]) == wanted, f"{kind}: unchecked {wanted - set(CHECKS[kind])}"


def test_every_bundled_preset_has_a_real_capture_test():
    names = {p.stem for p in (REPO / "presets" / "effects").glob("*.json")}
    assert names and set(PRESET_TESTS) == names, f"presets without one: {names - set(PRESET_TESTS)}"
    tree = ast.parse((TESTS / "blender" / "data" / "test_presets_capture.py").read_text())
    tests = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}
    consts = {t.id: ast.literal_eval(n.value) for n in tree.body if isinstance(n, ast.Assign)
              for t in n.targets if isinstance(t, ast.Name) and isinstance(n.value, ast.Tuple)}
    assert set(consts["CAPTURES"]) == set(CAPTURES)
    source = (TESTS / "blender" / "data" / "test_presets_capture.py").read_text()
    for preset, test in PRESET_TESTS.items():
        assert test in tests, f"{preset}: {test} is gone from test_presets_capture.py"
        body = ast.get_source_segment(source, tests[test])
        assert f'"{preset}"' in body, f"{test} does not apply {preset}"
        params = [ast.get_source_segment(source, d) for d in tests[test].decorator_list]
        if preset != "morph":  # morph: guitar into test64, both captures by construction
            assert any("CAPTURES" in p for p in params), f"{test} is not run on both captures"
        json.loads((REPO / "presets" / "effects" / f"{preset}.json").read_text())
    # and through the command line (the must-show), morph with two files
    cli = ast.parse((TESTS / "cli" / "test_cli_presets_capture.py").read_text())
    cli_presets = {ast.literal_eval(n.value) for n in cli.body if isinstance(n, ast.Assign)
                   for t in n.targets if getattr(t, "id", "") == "PRESETS"}
    (listed,) = cli_presets
    assert set(listed) | {"morph"} == names, f"not run from the command line: {names - set(listed)}"
