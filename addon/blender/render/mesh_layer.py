"""Meshes are seen: the mesh layer of a Splatline scene, drawn by one of Blender's engines.

A Splatline scene that holds visible surfaces (holdout_geometry.SURFACE_TYPES) and whose
Render > Splatline > Meshes is Drawn gets:

- a **mesh scene** (Scene.splatline.render.mesh_scene, named "<scene> (Splatline meshes)",
  marked MARK): the same surface objects, lights and light probes linked (not copied) into
  its own collections, the same camera, camera markers and world, and the engine chosen in
  Mesh Engine (Workbench, EEVEE, Cycles). Splat objects are never linked into it (Blender
  5.3 would draw them natively; older Blenders as points), nor collection instances or
  Geometry Nodes objects that would bring splats in (their meshes then stay out too); on
  5.3 with EEVEE or Cycles it holds a shadow-only caster of each (shadow_casters.py);
- a **compositor** in the Splatline scene: each Render Layers node of the scene's own layers
  goes through an Alpha Over node whose background is a Render Layers node of the
  mesh scene (mesh_compositor.py). With no compositor of the user's, Splatline makes one
  (Render Layers -> Alpha Over -> output) and removes it again when it is not needed.

Blender renders a scene that a Render Layers node references as part of the frame, at the
same frame, size and border: F12, `blender -b -a`, bpy.ops.render.render and
`python -m addon render` all give the same composite. Alpha Over with premultiplied
colours is combined = splat + (1 - splat_alpha) * mesh, exact for opaque meshes because
the engine held out the splat fragments behind them (holdout_geometry.py).

When: `sync(scene)` makes the set-up match the scene. It runs after depsgraph updates (an
edit, the engine chosen, an object added), after a file is loaded, and from the command
line before it renders; never during a render (Blender 5.3 crashes when a scene that the
compositor references changes in render_init). Every write is skipped where the value is
already right, so a sync that finds nothing to do changes nothing (no update loop).
"""
from __future__ import annotations

import bpy

from .. import compat
from ..props import render as render_props
from ..data.pointcloud import COMPANION_MARK
from ..data.sources import is_splat_object
from ..evaluate.holdout_geometry import is_surface
from ..evaluate.instancers import instances_splats
from . import mesh_compositor, shadow_casters

ENGINE = "SPLATLINE"
MARK = "splatline_meshes_of"          # on the mesh scene: the Splatline scene's name
LIGHT_TYPES = frozenset({"LIGHT", "LIGHT_PROBE", "LIGHTPROBE"})
# Render settings the mesh scene takes from the Splatline scene (size and border come from
# the Splatline render itself; these decide its projection, blur and timing).
COPIED = ("pixel_aspect_x", "pixel_aspect_y", "use_border", "use_crop_to_border",
          "border_min_x", "border_max_x", "border_min_y", "border_max_y",
          "resolution_x", "resolution_y", "resolution_percentage", "fps", "fps_base",
          "use_motion_blur", "motion_blur_shutter", "motion_blur_position")
ENGINES = {"WORKBENCH": ("BLENDER_WORKBENCH",), "EEVEE": ("BLENDER_EEVEE", "BLENDER_EEVEE_NEXT"),
           "CYCLES": ("CYCLES",)}
_busy = [0]       # render jobs running: no syncing then
_syncing = [False]  # a sync in progress (its own depsgraph update runs the handler again)
_wrote = [False]    # whether the sync in progress wrote anything


def _wrote_now():
    _wrote[0] = True


def _set(owner, name, value) -> bool:
    """owner.name = value unless it already is (no needless update tags); True if written."""
    if getattr(owner, name) != value:
        setattr(owner, name, value)
        _wrote_now()
        return True
    return False


# ---- which objects ----

def _layer_objects(layer_collection, flags, out):
    """Objects of the view layer's collection tree that the render sees, with the
    (holdout, indirect_only) flags of the collections above them."""
    collection = layer_collection.collection
    if layer_collection.exclude or collection.hide_render:
        return
    flags = (flags[0] or layer_collection.holdout, flags[1] or layer_collection.indirect_only)
    for obj in collection.objects:
        out.setdefault(obj, flags)
    for child in layer_collection.children:
        _layer_objects(child, flags, out)


def _collection_objects(collection, out):
    if collection.hide_render:
        return
    for obj in collection.objects:
        out.setdefault(obj, (False, False))
    for child in collection.children:
        _collection_objects(child, out)


def drawn_objects(scene, seen=None) -> dict:
    """{object: (holdout, indirect_only)} of what the mesh layer draws: surfaces, lights and
    light probes, and collection instances without splats in them, in the render-enabled
    view layers of scene (seen: render_objects(scene), where the caller has it)."""
    out = {}
    for obj, flags in (render_objects(scene) if seen is None else seen).items():
        if COMPANION_MARK in obj.keys() or is_splat_object(obj):
            continue
        if (is_surface(obj) or obj.type in LIGHT_TYPES
                or (obj.instance_type == "COLLECTION" and obj.instance_collection is not None)):
            if not instances_splats(obj):
                out[obj] = flags
    return out


def render_objects(scene) -> dict:
    """{object: (holdout, indirect_only)} of every object the render-enabled view layers of
    scene show."""
    found = {}
    for layer in scene.view_layers:
        if not layer.use:
            continue
        if layer.layer_collection is not None:
            _layer_objects(layer.layer_collection, (False, False), found)
        else:  # a new scene's layer, never synced (5.2+): no exclusions can be set on it yet
            _collection_objects(scene.collection, found)
    return found


def has_surfaces(objects) -> bool:
    return any(is_surface(o) or o.instance_type == "COLLECTION" for o in objects)


# ---- the mesh scene ----

def mesh_scene(scene):
    """The scene's mesh scene, or None."""
    companion = scene.splatline.render.mesh_scene
    return companion if companion is not None and companion.get(MARK) is not None else None


def is_mesh_scene(scene) -> bool:
    return scene.get(MARK) is not None


def engine_id(choice: str) -> str:
    """Blender's identifier of the Mesh Engine choice in this Blender (EEVEE is
    BLENDER_EEVEE_NEXT in 4.2-4.5, BLENDER_EEVEE in 5.x)."""
    known = {item.identifier for item in
             bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items}
    names = ENGINES[choice]
    return next((n for n in names if n in known), names[0])


def _ensure_scene(scene):
    companion = mesh_scene(scene)
    if companion is None:
        _wrote_now()
        companion = bpy.data.scenes.new(f"{scene.name} (Splatline meshes)")
        companion[MARK] = scene.name
        scene.splatline.render.mesh_scene = companion
        r = companion.render
        r.use_compositing = False
        r.use_sequencer = False
        companion.display.shading.color_type = "MATERIAL"
    return companion


def _child(companion, suffix, holdout=False, indirect=False, make=True):
    """The mesh scene's sub-collection for objects with these collection flags (None where
    there is none and make is False)."""
    coll = next((c for c in companion.collection.children if c.get(MARK) == suffix), None)
    if coll is None:
        if not make:
            return None
        _wrote_now()
        coll = bpy.data.collections.new(f"{companion.name} {suffix}")
        coll[MARK] = suffix
        companion.collection.children.link(coll)
    if holdout or indirect:
        view_layer = companion.view_layers[0]
        if view_layer.layer_collection is None:  # 5.2+: synced lazily
            view_layer.update()
        layer = view_layer.layer_collection.children.get(coll.name)
        _set(layer, "holdout", holdout)
        _set(layer, "indirect_only", indirect)
    return coll


_GROUPS = {(False, False): ("drawn", {}), (True, False): ("holdout", {"holdout": True}),
           (False, True): ("indirect", {"indirect": True}),
           (True, True): ("holdout indirect", {"holdout": True, "indirect": True})}


def _sync_objects(companion, objects):
    for flags, (suffix, kind) in _GROUPS.items():
        want = {o for o, f in objects.items() if f == flags}
        coll = _child(companion, suffix, make=bool(want), **kind)
        if coll is None:
            continue
        for obj in list(coll.objects):
            if obj not in want:
                _wrote_now()
                coll.objects.unlink(obj)
        for obj in want:
            if coll.objects.get(obj.name) != obj:
                _wrote_now()
                coll.objects.link(obj)
    for obj in list(companion.collection.objects):  # nothing loose in the master collection
        _wrote_now()
        companion.collection.objects.unlink(obj)


def _sync_casters(companion, sources) -> None:
    """The splat objects' shadow casters (shadow_casters.py) in the mesh scene."""
    if companion is None:
        return
    collection = _child(companion, shadow_casters.SUFFIX, make=bool(sources))
    shadow_casters.sync(collection, sources, _set, _wrote_now)


def _sync_settings(scene, companion):
    settings, r, src = scene.splatline.render, companion.render, scene.render
    _set(r, "engine", engine_id(settings.mesh_engine))
    for name in COPIED:
        if name in src.bl_rna.properties and name in r.bl_rna.properties:
            _set(r, name, getattr(src, name))
    # The world is drawn by the mesh engine, under meshes and splats alike (the splat layer
    # is rendered transparent then): film transparency is the Splatline scene's.
    _set(r, "film_transparent", src.film_transparent)
    _set(companion, "world", scene.world)
    _set(companion, "camera", scene.camera)
    _sync_markers(scene, companion)


def _sync_markers(scene, companion):
    """Camera switching: the mesh scene gets the Splatline scene's camera-bound markers."""
    want = [(m.frame, m.camera) for m in scene.timeline_markers if m.camera is not None]
    have = [(m.frame, m.camera) for m in companion.timeline_markers]
    if sorted(want, key=_marker_key) == sorted(have, key=_marker_key):
        return
    _wrote_now()
    companion.timeline_markers.clear()
    for frame, camera in want:
        companion.timeline_markers.new(f"F_{frame}", frame=frame).camera = camera


def _marker_key(pair):
    return pair[0], pair[1].name


# ---- the compositor (mesh_compositor.py) ----

def attached(scene) -> bool:
    """Whether the scene's final frame holds the mesh layer (mesh_compositor.holds)."""
    return mesh_compositor.holds(scene, mesh_scene(scene))


def why_not_attached(scene) -> str:
    """One line for the render's warning: why the mesh layer is not in the frame."""
    return mesh_compositor.why_not(scene, mesh_scene(scene))


# ---- sync ----

def wanted(scene) -> bool:
    return scene.render.engine == ENGINE and scene.splatline.render.meshes == "DRAW"


def sync(scene) -> bool:
    """Make the scene's mesh layer match it; True when anything was written.

    Call it where no depsgraph is being evaluated (a script, an operator, load_post), or
    as the depsgraph handler does: followed by depsgraph.update()."""
    if is_mesh_scene(scene) or not hasattr(scene, "splatline"):
        return False
    _wrote[0] = False
    seen = render_objects(scene) if wanted(scene) else {}
    objects = drawn_objects(scene, seen)
    if not has_surfaces(objects):
        mesh_compositor.detach(scene, _wrote_now)
        _sync_casters(mesh_scene(scene), [])
        return _wrote[0]
    companion = _ensure_scene(scene)
    _sync_objects(companion, objects)
    _sync_casters(companion, shadow_casters.sources(scene, seen))
    _sync_settings(scene, companion)
    mesh_compositor.attach(scene, companion, _wrote_now)
    return _wrote[0]


def _rendering() -> bool:
    if _busy[0]:
        return True
    is_running = getattr(bpy.app, "is_job_running", None)
    return bool(is_running and is_running("RENDER"))


@bpy.app.handlers.persistent
def _on_depsgraph_update(scene, depsgraph=None):
    """After an edit (and before a render: the render operator updates the depsgraph first).

    What sync links and makes must reach the depsgraph before Blender evaluates it again:
    Blender 5.2+ re-evaluates a depsgraph whose handler tagged changes without rebuilding
    it for collections that changed there, and crashes (SIGSEGV in
    deg_check_base_in_depsgraph, measured on bpy 5.2.3 and 5.3.0). The depsgraph's own
    update() here rebuilds and evaluates it first (this handler runs again inside it and
    returns at once)."""
    if _syncing[0] or _rendering() or scene is None:
        return
    if scene.render.engine != ENGINE and compat.active_compositor(scene) is None:
        return
    _syncing[0] = True
    try:
        if sync(scene) and depsgraph is not None:
            depsgraph.update()
    finally:
        _syncing[0] = False


@bpy.app.handlers.persistent
def _on_load(*_args):
    _busy[0] = 0
    for scene in bpy.data.scenes:
        if scene.render.engine == ENGINE and not is_mesh_scene(scene):
            sync(scene)


@bpy.app.handlers.persistent
def _job_started(*_args):
    _busy[0] += 1


@bpy.app.handlers.persistent
def _job_ended(*_args):
    _busy[0] = max(0, _busy[0] - 1)


def _setting_changed(scene):
    """Meshes or Mesh Engine set (panel, script, --engine-option): sync now, outside any
    depsgraph evaluation."""
    if not _rendering() and not _syncing[0] and scene is not None:
        sync(scene)


def hook_settings():
    if _setting_changed not in render_props.MESH_SETTING_HOOKS:
        render_props.MESH_SETTING_HOOKS.append(_setting_changed)


def unhook_settings():
    while _setting_changed in render_props.MESH_SETTING_HOOKS:
        render_props.MESH_SETTING_HOOKS.remove(_setting_changed)


def handlers():
    h = bpy.app.handlers
    return ((h.depsgraph_update_post, _on_depsgraph_update), (h.load_post, _on_load),
            (h.render_init, _job_started), (h.render_complete, _job_ended),
            (h.render_cancel, _job_ended))
