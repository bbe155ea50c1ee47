"""The render stages' one table and the renderers' one interface.

- Every shared number has one home, core/render_constants.py, and its GLSL twin in
  shaders/ holds the same value: read from the shader source and compared here (as the
  float32 the shader computes), so changing one side alone fails.
- docs/ARCHITECTURE.md's "Render stages" table names files that exist, and every shader
  file belongs to a stage.
- Every renderer is a core.renderer.Renderer and its declared capabilities are what it
  does: has_depth gives a Z pass, and a renderer without holdout, panorama or defocus
  refuses such a frame rather than drawing something else.
"""
from __future__ import annotations

import ast
import operator
import pathlib
import re

import numpy as np
import pytest

from addon.core import colorspace, reference, render_constants, sh
from addon.core.camera import equirect_camera, look_at, simple_camera
from addon.core.holdout import Holdout
from addon.core.renderer import CAPABILITIES, Renderer
from addon.core.scene import RenderItem, RenderOptions
from addon.gl import OffscreenRenderer, composite, holdout
from testing import doc_paths
from testing.gl_scenes import random_splats, world_for
from testing.paths import REPO

SHADERS = REPO / "shaders"
SHADER_SUFFIXES = {".glsl", ".comp", ".vert", ".frag"}
_OPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
        ast.Div: operator.truediv}


def _glsl_number(text: str) -> np.float32:
    """A GLSL constant expression of float literals (e.g. `1.0 / 255.0`), evaluated as
    float32 step by step, as the shader compiler does."""
    def value(node):
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return np.float32(node.value)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            return -value(node.operand)
        if isinstance(node, ast.BinOp) and type(node.op) in _OPS:
            return np.float32(_OPS[type(node.op)](value(node.left), value(node.right)))
        raise ValueError(f"not a plain float expression: {text!r}")

    return value(ast.parse(text.strip(), mode="eval").body)


def glsl_constants(name: str) -> dict[str, list[np.float32]]:
    """{shader file: [values]} of every `const float NAME = ...;` in shaders/."""
    pattern = re.compile(rf"^\s*const\s+float\s+{re.escape(name)}\s*=\s*([^;]+);", re.M)
    found = {}
    for path in sorted(SHADERS.iterdir()):
        values = pattern.findall(path.read_text(encoding="utf-8"))
        if values:
            found[path.name] = [_glsl_number(v) for v in values]
    return found


def _twins():
    """(python name, python value, GLSL name) of every pinned pair."""
    pairs = [(name, getattr(render_constants, name), glsl)
             for name, glsl in render_constants.GLSL_TWINS.items()]
    pairs += [("holdout.ENC_BASE", holdout.ENC_BASE, "SL_ENC_BASE"),
              ("holdout.HOLDOUT_BIAS", holdout.HOLDOUT_BIAS, "SL_HOLDOUT_BIAS"),
              ("sh.C0", sh.C0, "SL_SH_C0"), ("sh.C1", sh.C1, "SL_SH_C1"),
              ("colorspace._A", colorspace._A, "SL_SRGB_A"),
              ("colorspace._SRGB_KNEE", colorspace._SRGB_KNEE, "SL_SRGB_KNEE")]
    pairs += [(f"sh.C2[{i}]", c, f"SL_SH_C2_{i}") for i, c in enumerate(sh.C2)]
    pairs += [(f"sh.C3[{i}]", c, f"SL_SH_C3_{i}") for i, c in enumerate(sh.C3)]
    return pairs


@pytest.mark.parametrize("name, value, glsl", _twins(), ids=[t[0] for t in _twins()])
def test_glsl_twin_holds_the_python_value(name, value, glsl):
    found = glsl_constants(glsl)
    assert found, f"no `const float {glsl}` in shaders/ (twin of {name})"
    for shader, values in found.items():
        assert values == [np.float32(value)] * len(values), (shader, glsl, values, value)


def test_glsl_reader_sees_a_changed_literal():
    """The reader is not vacuous: a twin edited in the source reads back changed."""
    assert _glsl_number("1.0 / 255.0") == np.float32(1.0) / np.float32(255.0)
    assert _glsl_number("1.0e-4") == np.float32(render_constants.T_STOP)
    assert _glsl_number("1.0e-5") != np.float32(render_constants.T_STOP)


def test_constants_have_one_home():
    """The renderers read the shared numbers from render_constants, not copies."""
    from addon.core import preprocess

    assert preprocess.LOW_PASS is render_constants.LOW_PASS
    assert preprocess.ALPHA_MIN is render_constants.ALPHA_MIN
    assert reference.T_STOP is render_constants.T_STOP
    assert reference.MAX_ALPHA is render_constants.MAX_ALPHA
    assert composite.DEPTH_FROM_ALPHA is render_constants.DEPTH_FROM_ALPHA
    for module in ("core/reference.py", "core/preprocess.py", "gl/composite.py"):
        source = (REPO / "addon" / module).read_text(encoding="utf-8")
        assert not re.search(r"^(T_STOP|MAX_ALPHA|DEPTH_FROM_ALPHA|LOW_PASS|ALPHA_MIN)\s*=",
                             source, re.M), module


# ---- the stage table -------------------------------------------------------------------

def stage_table() -> list[dict]:
    text = (REPO / "docs" / "ARCHITECTURE.md").read_text(encoding="utf-8")
    start = text.index("| stage | reference | GL | viewport | test |")
    rows = []
    for line in text[start:].splitlines()[2:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip("|").split("|")]
        rows.append(dict(zip(("stage", "reference", "gl", "viewport", "test"), cells)))
    return rows


def _paths(cell: str) -> list[pathlib.Path]:
    """The files a cell names, where the docs' one rule puts them (testing/doc_paths.py)."""
    return [doc_paths.resolve(name) for name in re.findall(r"`([^`]+\.[a-z]+)`", cell)]


def test_stage_table_names_existing_files():
    rows = stage_table()
    assert [r["stage"].split(":")[0] for r in rows] == [
        "preprocess", "effects", "lighting", "sort", "composite", "holdout", "film", "shared"]
    for row in rows:
        for column in ("reference", "gl", "viewport", "test"):
            for path in _paths(row[column]):
                assert path.is_file(), (row["stage"], column, path)
        assert _paths(row["test"]), row["stage"]


def test_every_shader_is_in_a_stage():
    named = {p.name for row in stage_table() for c in ("gl", "viewport") for p in _paths(row[c])
             if p.parent == SHADERS}
    shaders = {p.name for p in SHADERS.iterdir() if p.suffix in SHADER_SUFFIXES}
    assert shaders - named == set()


def test_stage_names_pair_across_renderers():
    """Where a stage is a file of its own, each renderer's file carries the stage's name."""
    rows = {r["stage"].split(":")[0]: r for r in stage_table()}
    for stage in ("preprocess", "sort"):
        for column in ("reference", "gl", "viewport"):
            names = [p.name for p in _paths(rows[stage][column])]
            assert any(stage in n for n in names), (stage, column, names)


# ---- the renderers' interface ----------------------------------------------------------

def _scene():
    splats = random_splats(300, 1, seed=4)
    cam = simple_camera(48, 32, 50.0, look_at((0.0, -2.5, 0.3), (0.0, 0.0, 0.0)))
    return [RenderItem(splats, world=world_for(splats), key=("stages", 0))], cam


def _check_capabilities(renderer):
    assert isinstance(renderer, Renderer)
    for name in CAPABILITIES:
        assert isinstance(getattr(renderer, name), bool), name


def test_reference_renderer_is_the_reference():
    items, cam = _scene()
    r = reference.ReferenceRenderer()
    _check_capabilities(r)
    out, want = r.render(items, cam, RenderOptions()), reference.render(items, cam, RenderOptions())
    assert np.array_equal(out.rgba, want.rgba) and np.array_equal(out.depth, want.depth)
    assert r.has_depth and np.isfinite(out.depth).any()


@pytest.mark.parametrize("depth_pass", [True, False])
def test_offscreen_renderer_declares_its_depth_pass(depth_pass):
    items, cam = _scene()
    with OffscreenRenderer(depth_pass=depth_pass) as r:
        _check_capabilities(r)
        assert r.has_depth is depth_pass
        out = r.render(items, cam, RenderOptions())
    assert bool(np.isfinite(out.depth).any()) == depth_pass
    assert out.rgba[..., 3].max() > 0.5  # the splats are in the frame


def test_gpu_module_renderer_refuses_what_it_cannot_draw(bpy_empty):
    """Every capability the Blender-GPU path declares False is a frame it refuses."""
    from addon.blender.render.gpu_render import GpuModuleRenderer

    r = GpuModuleRenderer()
    try:
        _check_capabilities(r)
        assert not (r.has_depth or r.has_holdout or r.has_panorama or r.has_defocus
                    or r.has_early_termination)
        items, cam = _scene()
        wall = Holdout([[(-1.0, 0.0, -1.0), (1.0, 0.0, -1.0), (0.0, 0.0, 1.0)]])
        with pytest.raises(ValueError, match="meshes hiding splats"):
            r.render(items, cam, RenderOptions(holdout=wall))
        pano = equirect_camera(np.eye(4), 64, 32)
        with pytest.raises(ValueError, match="panoramic cameras"):
            r.render(items, pano, RenderOptions())
    finally:
        r.close()
