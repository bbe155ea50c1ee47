"""Scene.splatline.render: the Splatline engine's quality settings (core RenderOptions), and
what it does with the scene's meshes (render/mesh_layer.py)."""
import bpy

from ...core.scene import RenderOptions

# Explicit numbers: a .blend stores the number, and OFFSCREEN/REFERENCE keep the ones
# they had before AUTO and GPU_MODULE existed.
RENDERERS = (
    ("AUTO", "Auto", "Offscreen GL (moderngl) where it starts, else Blender's GPU module", 2),
    ("OFFSCREEN", "moderngl", "moderngl offscreen renderer on its own OpenGL context (GPU, or "
     "Mesa llvmpipe on CPU); fails where moderngl or its context is missing", 0),
    ("GPU_MODULE", "Blender GPU", "The viewport's drawing code through Blender's own GPU "
     "backend (OpenGL, Vulkan, Metal): no extra wheel or driver; no depth pass", 3),
    ("REFERENCE", "Reference",
     "Exact float64 per-pixel CPU renderer: slow, for checking the fast ones", 1),
)

MESH_MODES = (
    ("DRAW", "Drawn", "Meshes hide the splats behind them and are drawn under the splats by "
     "the Mesh Engine, through the compositor (one final frame)", 0),
    ("HOLDOUT", "Hide Splats Only", "Meshes hide the splats behind them but are not drawn: the "
     "frame is the splat layer, with holes, for compositing elsewhere", 1),
    ("IGNORE", "Ignored", "Splats only, as if there were no meshes", 2),
)
MESH_ENGINES = (
    ("WORKBENCH", "Workbench", "Solid shading with the materials' viewport colours: fast, "
     "also on a CPU rasterizer", 0),
    ("EEVEE", "EEVEE", "Materials, lights and shadows; slow on a CPU rasterizer", 1),
    ("CYCLES", "Cycles", "Path-traced materials and lights", 2),
)


# Called with the scene when Meshes or Mesh Engine change (render/mesh_layer.py puts its sync
# here at register: props/ imports nothing above it). Blender runs no depsgraph handler for
# a change of an add-on property alone.
MESH_SETTING_HOOKS: list = []


def _mesh_setting_changed(self, _context):
    for hook in MESH_SETTING_HOOKS:
        hook(self.id_data)


def _tag_scene(self, _context):
    """The handoff follows depsgraph updates of the scene: a setting it reads sends one."""
    self.id_data.update_tag()


class RenderSettings(bpy.types.PropertyGroup):
    renderer: bpy.props.EnumProperty(
        name="Renderer", items=RENDERERS, default="AUTO",
        description="Which implementation of the same splat semantics renders the frame")
    antialiased: bpy.props.BoolProperty(
        name="Anti-aliased", default=False,
        description="Compensate opacity for the 0.3 px low-pass filter (gsplat's "
                    "anti-aliased mode); use for captures trained that way")
    early_termination: bpy.props.BoolProperty(
        name="Early Termination", default=True,
        description="Stop a pixel once its transmittance drops below 1e-4, as INRIA's "
                    "tile rasterizer does: dense captures render faster "
                    "(moderngl and the reference; not the Blender GPU path)")
    capped_extent: bpy.props.BoolProperty(
        name="Capped Extent (3 sigma)", default=False,
        description="Cut each splat's quad at 3 sigma instead of its exact footprint (where "
                    "alpha falls to 1/255, 3.33 sigma at full opacity): faster, drops a faint "
                    "ring of alpha below 0.011")
    key_bits: bpy.props.EnumProperty(
        name="Sort Key Bits",
        items=(("16", "16-bit", "Faster sort; enough for most captures"),
               ("32", "32-bit", "Exact order for scenes with a wide depth range")),
        default="32", description="Precision of the back-to-front depth sort keys")
    gpu_sort: bpy.props.BoolProperty(
        name="GPU Sort", default=True,
        description="Sort on the GPU with compute shaders where OpenGL 4.3 is available "
                    "and the GL is a real GPU (on a CPU rasterizer such as Mesa llvmpipe "
                    "the CPU sorts faster, so it does); off: always on the CPU")

    motion_blur_samples: bpy.props.IntProperty(
        name="Motion Blur Samples", default=8, min=1, soft_max=32, max=256,
        description="Sub-frame renders averaged per frame when Output > Motion Blur is on "
                    "(shutter and position are Blender's); each costs one render")

    meshes: bpy.props.EnumProperty(
        name="Meshes", items=MESH_MODES, default="DRAW", update=_mesh_setting_changed,
        description="What the scene's meshes (and curves, text, surfaces, metaballs) do in a "
                    "Splatline render")
    mesh_engine: bpy.props.EnumProperty(
        name="Mesh Engine", items=MESH_ENGINES, default="WORKBENCH", update=_mesh_setting_changed,
        description="Blender's engine that draws the meshes under the splats (its settings "
                    "are those of the Mesh Scene)")
    mesh_scene: bpy.props.PointerProperty(
        name="Mesh Scene", type=bpy.types.Scene,
        description="The scene Splatline keeps for the mesh layer: the same meshes, lights, "
                    "camera and world, rendered by the Mesh Engine and composited under the "
                    "splats (made and kept in step automatically)")

    native_outliers: bpy.props.BoolProperty(
        name="Leave Out Far Outliers", default=True, update=_tag_scene,
        description="Blender 5.3+: hand Blender's own engines each capture without the few "
                    "splats (at most 0.1%) that sit more than 8x its size away. EEVEE "
                    "quantises splat centres against the whole cloud's bounds, so a few far "
                    "strays blur the whole capture. Splatline's own engine is not affected")

    def options(self, background=(0.0, 0.0, 0.0, 0.0)) -> RenderOptions:
        """The core RenderOptions these settings stand for."""
        return RenderOptions(
            antialiased=self.antialiased, early_termination=self.early_termination,
            capped_extent=self.capped_extent, key_bits=int(self.key_bits),
            gpu_sort=None if self.gpu_sort else False, background=tuple(background))


classes = (RenderSettings,)
