"""The Blender layer: each module here has register()/unregister().

The order matters: property groups before the operators and panels that use them,
and unregister runs in reverse.
"""
import importlib

_MODULES = (
    "properties",     # Object.splatline and Scene.splatline property groups
    "io_ops",         # import/export operators, menus, FileHandler
    "camera_track_ops",  # File > Import > Splat Camera Track
    "sequence_ops",   # splat sequence import, bake
    "effect_ops",     # effect stack operators
    "viewport",       # SpaceView3D draw handler
    "engine",         # the Splatline RenderEngine
    "panels",         # Object / Render properties panels, N sidebar
    "presets",        # render-output preset menu and operators
    "effect_presets", # effect preset menu (appended to the effect stack panel)
    "menus",          # Object > Splatline (effect and bake operators, for menus and F3)
)


def _modules():
    return [importlib.import_module(f".{name}", __name__) for name in _MODULES]


def register():
    done = []
    try:
        for module in _modules():
            module.register()
            done.append(module)
    except Exception:
        for module in reversed(done):
            module.unregister()
        raise


def unregister():
    for module in reversed(_modules()):
        module.unregister()
