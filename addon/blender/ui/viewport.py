"""Panels of the viewport: display options (Object properties) and statistics (N sidebar)."""
from __future__ import annotations

import bpy

from ..data.sources import is_splat_object


def _mb(n: int) -> str:
    return f"{n / (1024 * 1024):.1f} MB"


def _ms(seconds: float) -> str:
    return f"{seconds * 1e3:.2f} ms"


class SPLATLINE_PT_display(bpy.types.Panel):
    bl_label = "Splatline Display"
    bl_idname = "SPLATLINE_PT_display"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        return is_splat_object(context.object) and hasattr(context.object, "splatline")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        d = context.object.splatline.display
        layout.prop(d, "mode")
        layout.prop(d, "splat_scale")
        layout.prop(d, "max_sh_degree")
        layout.prop(d, "show_sh_only")
        layout.prop(d, "sort_key_bits")
        layout.prop(d, "frustum_culling")
        row = layout.row()
        row.active = d.frustum_culling
        row.prop(d, "cull_dilation")


class SPLATLINE_PT_viewport_stats(bpy.types.Panel):
    bl_label = "Viewport Statistics"
    bl_idname = "SPLATLINE_PT_viewport_stats"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Splatline"
    bl_order = 1  # below the tab's Animate panel (blender/panels.py)

    def draw(self, context):
        from ..viewport import drawer

        live = drawer()
        col = self.layout.column(align=True)
        if live is None:
            col.label(text="Viewport drawing is off")
            return
        s = live.stats
        for label, value in (("Splats", f"{s.total:,}"), ("Drawn", f"{s.drawn:,}"),
                             ("CPU memory", _mb(s.cpu_bytes)), ("GPU memory", _mb(s.gpu_bytes)),
                             ("Last sort", _ms(s.sort_seconds)), ("Upload", _ms(s.upload_seconds)),
                             ("Draw call", _ms(s.draw_seconds))):
            row = col.row()
            row.label(text=label)
            row.label(text=value)
        if live.last_error is not None:
            col.label(text=f"Error: {live.last_error}", icon="ERROR")


classes = (SPLATLINE_PT_display, SPLATLINE_PT_viewport_stats)


register, unregister = bpy.utils.register_classes_factory(classes)
