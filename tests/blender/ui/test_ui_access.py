"""How users reach Splatline in the UI, through real bpy: the N-sidebar tab, the menus
(which is also what Blender's F3 search looks through) and operator tooltips.

Background mode has no UI to draw into, so each panel's draw() runs against a layout
that records what it asks for; every property, operator, menu and icon it names is then
looked up in the running Blender. In the UI a wrong name only prints to the console and
leaves a hole in the panel, so this is where a typo shows.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from testing.engine_scene import add_splats, flat_splats
from testing.ui_layout import RecordingLayout, check_names_exist as _check_names_exist


def _draw(panel_cls, obj):
    layout = RecordingLayout()
    panel_cls.draw(SimpleNamespace(layout=layout), SimpleNamespace(active_object=obj))
    return layout.record


def _props(record):
    return [what[1] for kind, what, _ in record if kind == "prop"]


def test_sidebar_tab_holds_the_timeline_tools_and_statistics(bpy_empty):
    bpy = bpy_empty
    animate, output = bpy.types.SPLATLINE_PT_animate, bpy.types.SPLATLINE_PT_animate_output
    stats = bpy.types.SPLATLINE_PT_viewport_stats
    for panel in (animate, output, stats):
        assert (panel.bl_space_type, panel.bl_region_type, panel.bl_category) == ("VIEW_3D", "UI", "Splatline")
    assert animate.bl_order < stats.bl_order


def test_animate_panel_without_a_splat_object_offers_import(bpy_empty):
    bpy = bpy_empty
    record = _draw(bpy.types.SPLATLINE_PT_animate, None)
    _check_names_exist(bpy, record)
    assert ("operator", "import_scene.splatline_gaussians", "IMPORT") in record
    assert not bpy.types.SPLATLINE_PT_animate_output.poll(SimpleNamespace(active_object=None))


def test_animate_panel_shows_look_effects_and_sequence_timing(bpy_empty):
    bpy = bpy_empty
    obj = add_splats(bpy, "s", flat_splats(np.zeros((4, 3)), np.full((4, 3), 0.5)))
    with bpy.context.temp_override(object=obj, active_object=obj):
        for kind in ("REVEAL", "DISPLACE"):
            bpy.ops.splatline.effect_add(type=kind)
    record = _draw(bpy.types.SPLATLINE_PT_animate, obj)
    _check_names_exist(bpy, record)
    props = _props(record)
    assert {"opacity", "size", "exposure"} <= set(props)
    assert props.count("amount") == 2 and props.count("enabled") == 2  # one row per effect
    assert "speed" not in props  # not a sequence: no timing
    assert ("menu", "SPLATLINE_MT_effect_presets", "PRESET") in record

    obj.splatline.sequence.enabled = True
    timing = _props(_draw(bpy.types.SPLATLINE_PT_animate, obj))
    assert {"frame_offset", "speed", "loop_mode"} <= set(timing)

    context = SimpleNamespace(active_object=obj)
    assert bpy.types.SPLATLINE_PT_animate_output.poll(context)
    record = _draw(bpy.types.SPLATLINE_PT_animate_output, obj)
    _check_names_exist(bpy, record)
    assert {what for kind, what, _ in record if kind == "operator"} == {
        "splatline.bake_sequence", "export_scene.splatline_evaluated", "render.render"}


def test_every_operator_has_a_one_line_tooltip(bpy_empty):
    """Blender shows an operator's description as its tooltip (and in F3 search): it must
    exist, and a docstring's line break would show up as a break plus its indentation."""
    bpy = bpy_empty
    found = []
    for module in ("splatline", "import_scene", "export_scene"):
        for name in dir(getattr(bpy.ops, module)):
            if module == "splatline" or "splatline" in name:
                rna = getattr(getattr(bpy.ops, module), name).get_rna_type()
                found.append(name)
                assert rna.description.strip() and "\n" not in rna.description, (name, rna.description)
    assert len(found) >= 14  # import, export, sequence, bake, effects, presets


def _menu_operators(bpy, draw, context, seen=None) -> set:
    """Operators a menu draw function shows, following the submenus it opens."""
    seen = set() if seen is None else seen
    layout = RecordingLayout()
    draw(SimpleNamespace(layout=layout), context)
    _check_names_exist(bpy, layout.record)
    found = {what for kind, what, _ in layout.record if kind == "operator"}
    for kind, what, _ in layout.record:
        if kind == "menu" and what not in seen:
            seen.add(what)
            found |= _menu_operators(bpy, getattr(bpy.types, what).draw, context, seen)
    return found


def test_operators_are_reachable_from_blenders_menus(bpy_empty):
    """Every user-facing operator is in a menu under File or Object (so F3 finds it).
    Left to their panels: moving an effect in the stack, and adding a render-output
    preset (the + beside the preset menu, as in Blender's own preset panels)."""
    bpy = bpy_empty
    obj = add_splats(bpy, "s", flat_splats(np.zeros((4, 3)), np.full((4, 3), 0.5)))
    context = SimpleNamespace(active_object=obj, object=obj, scene=bpy.context.scene)
    reachable = set()
    for menu in ("TOPBAR_MT_file_import", "TOPBAR_MT_file_export", "VIEW3D_MT_object"):
        for draw in getattr(bpy.types, menu)._dyn_ui_initialize():
            if draw.__module__.startswith("addon."):
                reachable |= _menu_operators(bpy, draw, context)
    wanted = {"import_scene.splatline_gaussians", "import_scene.splatline_sequence",
              "export_scene.splatline_gaussians", "export_scene.splatline_evaluated",
              "splatline.bake_sequence", "splatline.effect_add", "splatline.effect_remove",
              "splatline.effect_duplicate", "splatline.effect_add_gizmo",
              "splatline.effect_preset_apply", "splatline.effect_preset_add"}
    assert wanted <= reachable, wanted - reachable
