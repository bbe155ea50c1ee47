"""Render properties panel for the Splatline engine (registered by engine.register)."""
import bpy

ENGINE = "SPLATLINE"


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
        layout.prop(settings, "renderer")
        col = layout.column(heading="Quality")
        col.prop(settings, "antialiased")
        col.prop(settings, "opacity_aware_extent")
        # Quad rasterizers cannot stop a pixel early; only the reference renderer can.
        if settings.renderer == "REFERENCE":
            col.prop(settings, "early_termination")
        col = layout.column(heading="Sorting")
        col.prop(settings, "key_bits")
        sub = col.row()
        sub.active = settings.renderer == "OFFSCREEN"
        sub.prop(settings, "gpu_sort")
        layout.prop(context.scene.render, "film_transparent")


classes = (SPLATLINE_PT_render,)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
