"""The one interface of every renderer, and what each can do.

A renderer turns the items of a frame into premultiplied sRGB RGBA and a Z pass through
three stages, each written once per renderer (docs/ARCHITECTURE.md, "Render stages"):
preprocess (project each splat), sort (back to front) and composite (blend the
footprints). Implementations: core/reference.ReferenceRenderer (float64 CPU oracle),
gl/offscreen_renderer.OffscreenRenderer (moderngl), and the engine's Blender-GPU path
blender/render/gpu_render.GpuModuleRenderer (the viewport's drawing code). The render
engine picks one (blender/render/backend.py) and reads its capabilities before a frame,
so they are declared by the renderer, never set on it from outside.
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

from .camera import Camera
from .scene import RenderItem, RenderOptions, RenderOutput

CAPABILITIES = ("has_depth", "has_holdout", "has_panorama", "has_defocus",
                "has_early_termination", "has_film")


@runtime_checkable
class Renderer(Protocol):
    """render(items, camera, options) -> RenderOutput, with the same semantics everywhere
    (core/reference.py states them); close() releases what the renderer holds.

    has_depth              RenderOutput.depth is the Z pass (else +inf everywhere)
    has_holdout            it honours options.holdout (meshes hiding splats)
    has_panorama           it draws equirectangular cameras
    has_defocus            it draws depth of field (camera.defocus)
    has_early_termination  it honours options.early_termination (else always blends all)
    has_film               it honours options.film (RenderOutput.combined; else that is None)
    """

    has_depth: bool
    has_holdout: bool
    has_panorama: bool
    has_defocus: bool
    has_early_termination: bool
    has_film: bool

    def render(self, items: list[RenderItem], camera: Camera,
               options: RenderOptions) -> RenderOutput: ...

    def close(self) -> None: ...
