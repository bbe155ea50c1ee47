"""The Splatline RenderEngine: F12, `blender -b -a`, and bpy.ops.render.render from bpy.

Blender makes a new engine instance for every frame, so the offscreen renderer (its
GL context, worker thread and GPU buffers) lives in a module-level holder instead:
created on the first frame of a render job, reused by the following frames, and
closed when the job completes or is cancelled, and on unregister.
Headless Ctrl+C stops a job between frames (core/stop.py).

Meshes (issue 25): the surfaces the depsgraph shows hide the splat fragments behind them
(RenderOptions.holdout from evaluate/holdout_geometry.py), and where the scene's mesh layer
is attached (mesh_layer.py: a scene of the same meshes, drawn by Blender's own engine and
composited under this engine's layer), this layer is the splats alone, transparent (the
world is drawn in the mesh layer), and its Depth pass is the combined frame's.
"""
from __future__ import annotations

import dataclasses
import threading
import traceback
from dataclasses import dataclass

import bpy

from ...core import shutter
from ...core.colorspace import premultiplied_srgb_to_linear as to_scene_linear
from ...core.errors import SplatFormatError
from ...core.holdout import combine_depth, holdout_depth
from ...core.scene import Film
from ...core.stop import SigintGuard, Stopped, stop_requested
from . import mesh_layer, motion_blur
from . import backend as render_backend
from .camera import camera_from_blender
from ..registration import app_handlers
from ..evaluate.holdout_geometry import clear_cache as clear_holdout_cache, holdout_for
from ..evaluate.items import any_antialiased, collect_items
from ..evaluate.lighting import lighting_for
from .film import blender_depth, region_camera, render_region, result_rect
from ..data.world import world_background


class _RendererHolder:
    """One renderer, shared by the frames of a render job; the lock covers F12 jobs
    running on Blender's render thread while unregister runs on the main thread."""

    def __init__(self):
        self._lock = threading.Lock()
        self._renderer = None
        self._kind = None
        self.label = ""

    def get(self, kind: str, depth: bool):
        """(renderer for kind, whether it was made just now); depth=False skips the GL
        depth pass (no Z pass wanted)."""
        with self._lock:
            fresh = self._renderer is None or self._kind != (kind, depth)
            if fresh:
                self._close_locked()
                self._renderer, self.label = render_backend.make_renderer(kind, depth)
                self._kind = (kind, depth)
            return self._renderer, fresh

    @property
    def alive(self) -> bool:
        return self._renderer is not None

    def close(self):
        with self._lock:
            self._close_locked()

    def _close_locked(self):
        renderer, self._renderer, self._kind = self._renderer, None, None
        if renderer is not None:
            renderer.close()


_HOLDER = _RendererHolder()
_WARNED: set = set()  # warnings given in this render job
_SIGINT = SigintGuard()


@dataclass
class _Frame:
    """What every view and sub-frame of one frame renders with."""

    depsgraph: object
    camera_obj: object
    renderer: object
    region: object
    options: object
    views: list
    meshes: str = "IGNORE"      # Scene.splatline.render.meshes
    mesh_depth: bool = False    # the Depth pass combines the surfaces' depth (mesh layer drawn)


class _Stopped(Exception):
    """Raised between stages when the user asked to stop (Esc, SIGINT)."""


class SplatlineRenderEngine(bpy.types.RenderEngine):
    bl_idname = "SPLATLINE"
    bl_label = "Splatline"
    bl_use_preview = False
    # Blender's GPU context is current in render(): the Blender-GPU path draws there
    # (backend.py). The moderngl path never touches it: its standalone context
    # lives on its own thread (DESIGN.md), so the two cannot clobber each other.
    bl_use_gpu_context = True
    bl_use_postprocess = True

    def render(self, depsgraph):
        try:
            self._render(depsgraph)
        except (_Stopped, Stopped, KeyboardInterrupt):
            # An ERROR report makes Blender break the job: no file for this frame.
            self.report({"ERROR"}, "Splatline: render interrupted")
        except (SplatFormatError, ValueError) as exc:
            self.report({"ERROR"}, f"Splatline: {exc}")
        except Exception as exc:  # a bug: show the traceback, but still stop cleanly
            traceback.print_exc()
            self.report({"ERROR"}, f"Splatline: {type(exc).__name__}: {exc}")

    def _check(self):
        if self.test_break() or stop_requested():
            raise _Stopped()

    def _render(self, depsgraph):
        scene = depsgraph.scene
        settings = scene.splatline.render
        camera_obj = self.camera_override or scene.camera
        if camera_obj is None:
            raise ValueError(f"scene {scene.name!r} has no camera")
        full = camera_from_blender(scene, camera_obj, depsgraph)
        r = scene.render
        region = render_region(full.width, full.height, r.use_border,
                               (r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y))
        self.update_stats("", "Splatline | gathering splats")
        times = motion_blur.sub_frame_times(scene, scene.frame_current)
        items = collect_items(depsgraph)
        self._check()
        drawn = settings.meshes == "DRAW" and mesh_layer.attached(scene)
        # One setting for the whole scene, so view layers do not swap renderers mid-job.
        want_depth = any(layer.use and layer.use_pass_z for layer in scene.view_layers)
        renderer, fresh = _HOLDER.get(settings.renderer, want_depth)
        if fresh and want_depth and not renderer.has_depth:  # once per job, not per frame
            self.report({"WARNING"}, f"Splatline: {_HOLDER.label} has no depth pass: "
                                     "Depth holds the background value everywhere")
        if settings.meshes == "DRAW" and not drawn:
            self._warn_meshes_not_drawn(scene, depsgraph)
        blur = f" | motion blur {len(times)} samples" if times else ""
        self.update_stats("", f"Splatline | {_HOLDER.label} | "
                              f"{sum(i.splats.count for i in items):,} splats{blur}")
        result = self.begin_result(0, 0, region.width, region.height,
                                   layer=depsgraph.view_layer.name)
        try:
            if (result.resolution_x, result.resolution_y) != (region.width, region.height):
                raise ValueError(f"render result is {result.resolution_x}x{result.resolution_y}, "
                                 f"expected the region {region.width}x{region.height}")
            # The world: under the mesh layer where it is drawn, else under the splats
            # (the evaluated world: its colour may be animated).
            world = None if r.film_transparent or drawn else \
                world_background(depsgraph.scene_eval.world)
            options = settings.options()
            if not options.antialiased and any_antialiased(depsgraph):  # a flagged capture
                options = dataclasses.replace(options, antialiased=True)
            if renderer.has_film and not times:  # the renderer converts its frame itself
                options = dataclasses.replace(
                    options, film=Film(None if world is None else tuple(world)))
            # One view, or each eye of a stereo/multi-view render.
            frame = _Frame(depsgraph, camera_obj, renderer, region, options,
                           [v.name for v in result.views], settings.meshes, drawn and want_depth)
            # films: display sRGB from the renderer; motion blur's average is scene-linear
            films = self._blurred(frame, times) if times else self._films(frame, items)
            for view, (rgba, depth, film) in films.items():
                if film is None:
                    film = result_rect(rgba, world, srgb=not times)
                _write_view(result, view, film, depth)
        except BaseException:
            self.end_result(result, cancel=True)
            raise
        self.end_result(result)
        self.update_progress(1.0)

    def _warn_meshes_not_drawn(self, scene, depsgraph):
        """Once per job: surfaces hide splats, but the frame will not show them."""
        if "meshes" in _WARNED or holdout_for(depsgraph) is None:
            return
        _WARNED.add("meshes")
        self.report({"WARNING"}, "Splatline: meshes hide splats but are not drawn: "
                                 + mesh_layer.why_not_attached(scene))

    def _films(self, frame, items) -> dict:
        """{view: (the renderer's premultiplied sRGB RGBA, its view depth, its film or None)}
        of the scene as the depsgraph holds it now (result_rect, where the renderer made no
        film, and _write_view put them in Blender's terms)."""
        films = {}
        options = frame.options
        holdout = holdout_for(frame.depsgraph) if frame.meshes != "IGNORE" else None
        if holdout is not None:
            options = dataclasses.replace(options, holdout=holdout)
        for view in frame.views:
            self.active_view_set(view)
            camera = self._view_camera(frame.depsgraph.scene, frame.camera_obj, frame.depsgraph)
            camera = region_camera(camera, frame.region)
            out = frame.renderer.render(items, camera, options)
            self._check()
            depth = out.depth
            if frame.mesh_depth and holdout is not None and frame.renderer.has_depth:
                depth = combine_depth(depth, out.rgba[..., 3], holdout_depth(holdout, camera))
            films[view] = (out.rgba, depth, out.combined)
        return films

    def _blurred(self, frame, times) -> dict:
        """Motion blur: the films at each sub-frame time, averaged in scene-linear light
        (core/shutter.py); depth from the sample nearest the middle of the shutter. The
        scene is put back on its own frame afterwards, whatever happens."""
        scene = frame.depsgraph.scene
        current = scene.frame_current
        sums = {view: shutter.Average(len(times)) for view in frame.views}
        depth, middle = {}, shutter.nearest_to_middle(times)
        try:
            for k, time in enumerate(times):
                self.frame_set(*shutter.split_time(time))
                for view, (rgba, z, _) in self._films(frame, collect_items(frame.depsgraph)).items():
                    sums[view].add(to_scene_linear(rgba))
                    if k == middle:
                        depth[view] = z
        finally:
            self.frame_set(current, 0.0)
        return {view: (sums[view].result(), depth[view], None) for view in frame.views}

    def _view_camera(self, scene, camera_obj, depsgraph):
        """The camera of the active view: Blender offsets it per eye in multi-view renders."""
        obj = camera_obj.evaluated_get(depsgraph)
        return camera_from_blender(scene, camera_obj, depsgraph,
                                   matrix_world=self.camera_model_matrix(obj),
                                   shift_x=self.camera_shift_x(obj))

    def update_render_passes(self, scene=None, renderlayer=None):
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        if renderlayer.use_pass_z:
            self.register_pass(scene, renderlayer, "Depth", 1, "Z", "VALUE")

    def view_update(self, context, depsgraph):
        # Rendered viewport shading: read the splats when the depsgraph changes, not per redraw.
        self._view_items = _viewport_items(depsgraph)
        self._view_lighting = lighting_for(self._view_items, depsgraph)

    def view_draw(self, context, depsgraph):
        """Rendered viewport shading: the world (or nothing) behind the viewport's splat drawing.

        The viewport framebuffer is display space; with the Standard view that is sRGB,
        the space the splats are blended in.
        """
        import gpu

        from ...core.colorspace import linear_to_srgb
        from .. import viewport
        from ..viewport.viewport_renderer import DrawSettings

        scene = depsgraph.scene_eval
        framebuffer = gpu.state.active_framebuffer_get()
        if scene.render.film_transparent:
            framebuffer.clear(color=(0.0, 0.0, 0.0, 0.0))
        else:
            background = linear_to_srgb(world_background(scene.world))
            framebuffer.clear(color=(*(float(c) for c in background), 1.0))
        if getattr(self, "_view_items", None) is None:
            self.view_update(context, depsgraph)
        items = self._view_items
        region, rv3d = context.region, context.region_data
        if items and region is not None and rv3d is not None:
            gpu.state.depth_test_set("NONE")
            viewport.draw_items(items, rv3d.view_matrix, rv3d.window_matrix,
                                (region.width, region.height), DrawSettings(lighting=self._view_lighting))


def _viewport_items(depsgraph):
    """Items for the viewport's drawing path, which applies colour effects and lighting itself."""
    from ..viewport.effect_rows import on_gpu

    return collect_items(depsgraph, defer=on_gpu, defer_lighting=True)


def _write_view(result, view, rect, depth):
    """rect: the Combined pass (film.result_rect); depth: the renderer's, top-down, put in
    Blender's terms only where the layer has a Depth pass."""
    passes = result.layers[0].passes
    passes.find_by_name("Combined", view).rect.foreach_set(rect)
    depth_pass = passes.find_by_name("Depth", view)
    if depth_pass is not None:
        depth_pass.rect.foreach_set(blender_depth(depth[::-1]).ravel())


@bpy.app.handlers.persistent
def _job_started(*_args):
    _SIGINT.job_started(bpy.app.background)


@bpy.app.handlers.persistent
def _job_finished(*_args):
    _WARNED.clear()
    _HOLDER.close()
    _SIGINT.job_ended()


_JOB_HANDLERS = (("render_init", _job_started), ("render_complete", _job_finished),
                 ("render_cancel", _job_finished))


_register_classes, _unregister_classes = bpy.utils.register_classes_factory((SplatlineRenderEngine,))
_register_mesh_layer, _unregister_mesh_layer = app_handlers(mesh_layer.handlers(),
                                                            on_unregister=clear_holdout_cache)


def register():
    _register_classes()
    for name, fn in _JOB_HANDLERS:
        getattr(bpy.app.handlers, name).append(fn)
    _register_mesh_layer()
    mesh_layer.hook_settings()


def unregister():
    mesh_layer.unhook_settings()
    _unregister_mesh_layer()
    for name, fn in _JOB_HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        while fn in handlers:
            handlers.remove(fn)
    _HOLDER.close()
    _SIGINT.job_ended()
    _unregister_classes()
