"""The Blender layer: each module here has register()/unregister().

The order matters: property groups before the operators and panels that use them,
and unregister runs in reverse.
"""
import atexit
import importlib

_MODULES = (
    "props.root",         # Object.splatline and Scene.splatline property groups
    "evaluate.items",     # the base-splat cache and the handlers that invalidate it
    "data.sequence_source",  # the sequence frame cache, its read-ahead thread and handler
    "data.dynamic_source",   # the dynamic captures read back from their PointClouds
    "evaluate.native_handoff",   # evaluated splats into the geometry Blender's engines draw (5.3+)
    "ops.io",             # import/export operators, menus, FileHandler
    "ops.dynamic",        # File > Import > Dynamic Splat Capture
    "ops.camera_track",   # File > Import > Splat Camera Track
    "ops.sequence",       # splat sequence import, bake
    "ops.apply_transform",  # Object > Apply > Splat Rotation & Scale
    "ops.effects",        # effect stack operators
    "ui.object_panels",   # Object properties: sequence, look, effects (shown in this order)
    "viewport",           # SpaceView3D draw handler
    "ui.viewport",        # the viewport's display and statistics panels
    "render.engine",      # the Splatline RenderEngine
    "ui.render_panel",    # its Render-properties panel; opts built-in panels in (COMPAT_ENGINES)
    "ui.sidebar",         # the N sidebar's Splatline tab
    "ops.presets",        # render-output preset add/remove operator
    "ops.effect_presets", # effect preset operators
    "ui.presets",         # preset menus, Output panel; appends to the effects panel
    "ui.menus",           # Object > Splatline (effect and bake operators, for menus and F3)
)



def _modules():
    return [importlib.import_module(f".{name}", __name__) for name in _MODULES]


def _unregister_at_exit():
    """Tear the add-on down before the bpy module does.

    bpy 4.5 frees its space types and other globals in C++ static destructors after
    Python has finalised: with our draw handler still on SpaceView3D the process dies
    with SIGSEGV at exit (gdb: cb_customdata_free -> PyGILState_Ensure), and with the
    rest still registered it can hang in a destructor. atexit runs LIFO, so this runs
    before bpy's own exit hook. Inside Blender, add-ons are disabled (unregister drops
    this hook) before Blender tears down, so it never runs there."""
    unregister()


_registered = False


def register():
    global _registered
    done = []
    try:
        for module in _modules():
            module.register()
            done.append(module)
    except Exception:
        for module in reversed(done):
            module.unregister()
        raise
    _registered = True
    atexit.register(_unregister_at_exit)


def unregister():
    """Tear everything down once: a second call, with nothing registered, does nothing.

    The bpy module's exit disables every enabled add-on (bpy.utils._on_exit ->
    addon_utils.disable_all) after our atexit hook has already run (LIFO), so an add-on
    enabled through Blender (the installed extension zip) is unregistered twice at exit;
    the second pass used to fail on the first class it met (SPLATLINE_MT_object)."""
    global _registered
    atexit.unregister(_unregister_at_exit)
    if not _registered:
        return
    _registered = False
    for module in reversed(_modules()):
        module.unregister()
