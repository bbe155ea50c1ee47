"""Render properties panel for the Splatline engine, and the built-in panels it opts in to.

Where Blender renders splats itself (5.3+), one line under the Render Engine selector and one
in Splatline's panel say how the engines differ: Blender's blend splats in linear light,
Splatline's as the capture was trained (README, "Splatline's engine or Blender's own").

Registered from blender/__init__._MODULES right after render/engine.py (render/ never imports ui/)."""
import bpy

from ..data import native
from ..data.sources import is_splat_object

ENGINE = "SPLATLINE"
# Blender's engines that render native splats (EEVEE is BLENDER_EEVEE_NEXT in 4.2 .. 4.5)
NATIVE_ENGINES = frozenset({"BLENDER_EEVEE", "BLENDER_EEVEE_NEXT", "CYCLES", "BLENDER_WORKBENCH"})
SPLATLINE_HINT = "Blends in sRGB as trained; EEVEE/Cycles blend in linear light"
NATIVE_HINT = "Splats blend in linear light; Splatline engine: trained look"
# measured on 5.3.0: a sun and a point light leave EEVEE's and Cycles' splats bit-identical
NATIVE_LIGHT_HINT = "Lights do not light splats here; Splatline engine: Look > Lighting"


class SPLATLINE_PT_render(bpy.types.Panel):
    bl_label = "Splatline"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.scene.splatline.render
        if native.has_native_splats():
            layout.label(text=SPLATLINE_HINT, icon="INFO")
        layout.prop(settings, "renderer")
        _draw_path(layout, settings.renderer)
        col = layout.column(heading="Quality")
        col.prop(settings, "antialiased")
        col.prop(settings, "capped_extent")
        # Quad rasterizers cannot stop a pixel early; only the reference renderer can.
        if settings.renderer == "REFERENCE":
            col.prop(settings, "early_termination")
        col = layout.column(heading="Sorting")
        col.prop(settings, "key_bits")
        sub = col.row()
        sub.active = settings.renderer in {"AUTO", "OFFSCREEN"}
        sub.prop(settings, "gpu_sort")
        layout.prop(context.scene.render, "film_transparent")
        _draw_meshes(layout, settings)
        _draw_motion_blur(layout, context.scene)


def _draw_meshes(layout, settings) -> None:
    """Meshes (issue 25): what they do, which of Blender's engines draws them, and the
    scene Splatline keeps for that (its own render settings: samples, shading)."""
    col = layout.column(heading="Meshes")
    col.prop(settings, "meshes", text="Meshes")
    sub = col.column()
    sub.active = settings.meshes == "DRAW"
    sub.prop(settings, "mesh_engine")
    if settings.mesh_scene is not None:
        row = sub.row()
        row.enabled = False
        row.prop(settings, "mesh_scene", text="Mesh Scene")


def _draw_motion_blur(layout, scene) -> None:
    """Blender's own motion-blur switch and shutter, with Splatline's sample count."""
    r = scene.render
    col = layout.column(heading="Motion Blur")
    col.prop(r, "use_motion_blur", text="")
    sub = col.column()
    sub.active = r.use_motion_blur
    sub.prop(r, "motion_blur_shutter")
    if "motion_blur_position" in r.bl_rna.properties:
        sub.prop(r, "motion_blur_position")
    sub.prop(scene.splatline.render, "motion_blur_samples", text="Samples")


def path_text(kind: str) -> str:
    """What the panel says about the path: the last render's, else what will be tried."""
    from ..render import backend as render_backend

    label = render_backend.last_label()
    if label:
        return f"Last render: {label}"
    if kind == "AUTO" and not render_backend.moderngl_installed():
        return "Will use: Blender GPU module (fallback: moderngl not installed)"
    return "Path is chosen at the first render"


def _draw_path(layout, kind: str) -> None:
    row = layout.row()
    row.alignment = "RIGHT"
    text = path_text(kind)
    row.label(text=text, icon="ERROR" if "fallback" in text else "INFO")


def engine_hint(context) -> str | None:
    """The line under the Render Engine selector: for Blender's own engines, where this
    Blender renders splats and the scene holds some; None elsewhere."""
    if context.engine not in NATIVE_ENGINES or not native.has_native_splats():
        return None
    if not any(is_splat_object(obj) for obj in context.scene.objects):
        return None
    return NATIVE_HINT


def _draw_engine_hint(self, context) -> None:
    """Appended to RENDER_PT_context, the panel that holds the Render Engine selector."""
    text = engine_hint(context)
    if text:
        self.layout.label(text=text, icon="INFO")
        self.layout.label(text=NATIVE_LIGHT_HINT, icon="LIGHT")
        self.layout.prop(context.scene.splatline.render, "native_outliers")


classes = (SPLATLINE_PT_render,)

# Blender's own panels show only for the engines in their COMPAT_ENGINES: without these,
# a Splatline scene would have no Format, Frame Range, Output, Encoding, Metadata, Colour
# Management or camera Lens panels. Only the panels whose settings the engine honours.
BUILTIN_PANELS = (
    "RENDER_PT_format", "RENDER_PT_frame_range", "RENDER_PT_time_stretching",
    "RENDER_PT_output", "RENDER_PT_output_color_management", "RENDER_PT_output_views",
    "RENDER_PT_output_pixel_density", "RENDER_PT_encoding", "RENDER_PT_encoding_video",
    "RENDER_PT_encoding_audio", "RENDER_PT_stamp", "RENDER_PT_stamp_note", "RENDER_PT_stamp_burn",
    "RENDER_PT_post_processing", "RENDER_PT_color_management",
    "RENDER_PT_color_management_advanced", "RENDER_PT_color_management_curves",
    "RENDER_PT_color_management_white_balance", "RENDER_PT_color_management_working_space",
    "VIEWLAYER_PT_context_layer", "VIEWLAYER_PT_layer", "VIEWLAYER_PT_layer_passes",
    "VIEWLAYER_PT_workbench_layer_passes_data",  # Combined and Z: the passes the engine writes
    "WORLD_PT_context_world", "WORLD_PT_custom_props", "WORLD_PT_animation",
    "DATA_PT_context_camera", "DATA_PT_lens", "DATA_PT_camera", "CAMERA_PT_presets",
    "DATA_PT_camera_safe_areas", "DATA_PT_camera_safe_areas_center_cut", "CAMERA_PT_safe_areas_presets",
    "DATA_PT_camera_background_image", "DATA_PT_camera_display",
    "DATA_PT_camera_display_composition_guides", "DATA_PT_camera_animation",
    "DATA_PT_custom_props_camera", "DATA_PT_context_pointcloud", "DATA_PT_pointcloud_attributes",
    "DATA_PT_custom_props_pointcloud", "OBJECT_PT_visibility",
)


_patched: list = []  # the built-in panel classes register() added ENGINE to, for unregister


def _builtin_panels():
    for name in BUILTIN_PANELS:
        panel = getattr(bpy.types, name, None)  # absent in some Blender versions
        if panel is not None and isinstance(getattr(panel, "COMPAT_ENGINES", None), set):
            yield panel


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)


def register():
    _register_classes()
    engine_panel = getattr(bpy.types, "RENDER_PT_context", None)
    if engine_panel is not None:  # a draw function added the usual way (Panel.append)
        engine_panel.append(_draw_engine_hint)
    # The one place Splatline edits classes it does not own: Blender's panels read
    # COMPAT_ENGINES at draw time, so adding ENGINE to the set is how a custom engine gets them.
    # Only panels that did not list ENGINE already are recorded, so unregister undoes exactly
    # what register did.
    for panel in _builtin_panels():
        if ENGINE not in panel.COMPAT_ENGINES:
            panel.COMPAT_ENGINES.add(ENGINE)
            _patched.append(panel)


def unregister():
    while _patched:
        _patched.pop().COMPAT_ENGINES.discard(ENGINE)
    engine_panel = getattr(bpy.types, "RENDER_PT_context", None)
    if engine_panel is not None:
        engine_panel.remove(_draw_engine_hint)
    _unregister_classes()
