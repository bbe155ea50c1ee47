"""The Render tab's one-line hint on how the engines blend splats, drawn
through real bpy against test_ui_access's recording layout: on a Blender with native splats
(5.3) Splatline's panel says it blends as trained and, under the Render Engine selector,
Blender's own engines say they blend in linear light when the scene holds splats; on one
without (4.5 .. 5.2) neither line shows. Both panels draw without error either way."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from testing.engine_scene import add_splats, flat_splats
from testing.ui_layout import RecordingLayout, check_names_exist as _check_names_exist


def _labels(record):
    return [text for kind, text, _ in record if kind == "label"]


def _draw(draw, context):
    layout = RecordingLayout()
    draw(SimpleNamespace(layout=layout), context)
    return layout.record


def _engine_panel_draws(bpy, context):
    """Every draw function Splatline appended to RENDER_PT_context, run on `context`."""
    from addon.blender.ui import render_panel

    draws = [d for d in bpy.types.RENDER_PT_context._dyn_ui_initialize()
             if d is render_panel._draw_engine_hint]
    assert len(draws) == 1  # registered once, by render_panel.register
    return _draw(draws[0], context)


def test_splatline_panel_draws_and_says_how_it_blends_where_blender_has_native_splats(bpy_empty):
    from addon.blender.data import native
    from addon.blender.ui import render_panel

    bpy = bpy_empty
    scene = bpy.context.scene
    context = SimpleNamespace(scene=scene, engine=render_panel.ENGINE)
    record = _draw(bpy.types.SPLATLINE_PT_render.draw, context)
    _check_names_exist(bpy, record)
    assert "renderer" in [what[1] for kind, what, _ in record if kind == "prop"]
    hint = render_panel.SPLATLINE_HINT in _labels(record)
    assert hint == native.has_native_splats()
    assert "\n" not in render_panel.SPLATLINE_HINT and len(render_panel.SPLATLINE_HINT) <= 64


def test_blenders_engines_get_the_linear_light_line_only_with_splats_and_native_splats(bpy_empty):
    from addon.blender.data import native
    from addon.blender.ui import render_panel

    bpy = bpy_empty
    scene = bpy.context.scene
    cycles = SimpleNamespace(scene=scene, engine="CYCLES")
    assert _engine_panel_draws(bpy, cycles) == []  # no splat object: nothing to say
    add_splats(bpy, "s", flat_splats(np.zeros((4, 3)), np.full((4, 3), 0.5)))
    expected = [render_panel.NATIVE_HINT, render_panel.NATIVE_LIGHT_HINT] if native.has_native_splats() else []
    for engine in ("CYCLES", "BLENDER_WORKBENCH", "BLENDER_EEVEE"):
        record = _engine_panel_draws(bpy, SimpleNamespace(scene=scene, engine=engine))
        _check_names_exist(bpy, record)
        assert _labels(record) == expected, engine
    # Splatline's own engine, and engines that do not render Blender's splats: no line
    for engine in (render_panel.ENGINE, "SOME_OTHER_ENGINE"):
        assert _engine_panel_draws(bpy, SimpleNamespace(scene=scene, engine=engine)) == []
    for line in (render_panel.NATIVE_HINT, render_panel.NATIVE_LIGHT_HINT):
        assert "\n" not in line and len(line) <= 70
