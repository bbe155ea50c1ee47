"""DisplaySettings: per-object viewport display options (Object.splatline.display).

Viewport-only: they change how the 3D viewport draws a splat object, never what
F12 renders. The options of the seed viewers: splat scale, SH degree cap, point
cloud / opaque-quad modes, "SH only", frustum culling and sort-key precision.
"""
import bpy


def _redraw(self, context):
    screen = getattr(context, "screen", None)
    for area in getattr(screen, "areas", ()):
        if area.type == "VIEW_3D":
            area.tag_redraw()


class DisplaySettings(bpy.types.PropertyGroup):
    splat_scale: bpy.props.FloatProperty(
        name="Splat Scale", default=1.0, min=0.0, soft_min=0.05, soft_max=4.0,
        description="Multiplies every splat's size in the viewport", update=_redraw)
    max_sh_degree: bpy.props.IntProperty(
        name="Max SH Degree", default=3, min=0, max=3,
        description="Spherical-harmonics bands drawn in the viewport (0: base colour only)",
        update=_redraw)
    mode: bpy.props.EnumProperty(
        name="Display", default="GAUSSIAN", update=_redraw,
        items=(("GAUSSIAN", "Splats", "Gaussian splats, as rendered"),
               ("POINTS", "Points", "Point cloud: the splat centres only"),
               ("OPAQUE", "Opaque", "Opaque ellipses without the Gaussian falloff, to see each splat's extent")))
    show_sh_only: bpy.props.BoolProperty(
        name="SH Only", default=False, update=_redraw,
        description="Draw only the view-dependent SH bands over grey (no base colour)")
    frustum_culling: bpy.props.BoolProperty(
        name="Frustum Culling", default=True, update=_redraw,
        description="Skip splats whose centre is outside the view (grown by the dilation)")
    cull_dilation: bpy.props.FloatProperty(
        name="Dilation", default=0.2, min=0.0, soft_max=2.0, update=_redraw,
        description="Grow the culling frustum by this fraction, so large splats just outside still show")
    sort_key_bits: bpy.props.EnumProperty(
        name="Sort Precision", default="16", update=_redraw,
        items=(("16", "16-bit", "Depth keys quantised to 65536 steps over the visible range (fastest)"),
               ("32", "32-bit", "Depth keys quantised to 2^32 steps (two radix passes)")))


classes = (DisplaySettings,)
